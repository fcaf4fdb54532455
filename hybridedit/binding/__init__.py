"""The binding of the shape to its cage: truncated mean value coordinates (the kernels, the truncation rule),
the binding of each part to its piece, the cache, and the rig that holds cage and binding together."""
