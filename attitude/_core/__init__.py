"""Internal compiled layer: numba kernels on plain floats and float arrays.

Nothing here validates input or knows about units or xarray; the public modules of
``attitude`` do that once, at the boundary, and then call these kernels.
"""
