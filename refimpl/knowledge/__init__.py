"""The paper's background knowledge: the event calculus and its event table (Sigma_dyn), the spatial relations (Sigma_st)."""
