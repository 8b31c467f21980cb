"""refimpl: online visual abduction for multi-object tracking, as an ASP model and an equivalent CP-SAT model."""

__version__ = "0.1.0"
