"""A test kernel of the texton's slope beside its value (tests/noise/test_relief.py): the derivative kernels'
``texton_slope`` and the value kernels' ``texton_value`` at given offsets y from an impact."""

import warp as wp

from warp_texton.kernels import noise_gradient, noise_raster


@wp.kernel
def slope_and_value(coeffs: wp.array2d(dtype=wp.vec3), order: int, ys: wp.array(dtype=wp.vec2),
                    slopes: wp.array(dtype=wp.mat33), values: wp.array(dtype=wp.vec3)):
    t = wp.tid()
    slopes[t] = noise_gradient.texton_slope(coeffs, 0, coeffs.shape[0], ys[t], order)
    values[t] = noise_raster.texton_value(coeffs, 0, coeffs.shape[0], ys[t], order)
