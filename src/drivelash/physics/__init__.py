"""Pure physical models: @njit kernels and thin NumPy wrappers."""
