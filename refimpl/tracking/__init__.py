"""Algorithm 1 (tracking with abduction) and SORT: the stateful loops, their motion model, options, presets, and the one pipeline every command tracks through."""
