"""The frame problem <VO_t, P_t, ML_t>, its fact format, IoU, the confidence of a detection, the hypothesis and its priorities, the model constants and integer ranges."""
