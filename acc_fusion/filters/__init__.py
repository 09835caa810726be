"""Stage 3, local filters: the motion model, the Kalman filter kernels and their engines
(filterpy reference and batched), the steady-state filter and the ego-motion filter.
"""
