"""Type stubs of the Rust extension; the documented API is in roadtex.contact and friends.

Errors: every function raises the classes of roadtex.errors: InvalidInputError (a ValueError) for
unusable arguments, SolverError when the dense direct solver fails, ClappError when Clapp's model
fails, and InternalError (with the panic's message) if the Rust core panics.
"""

import numpy as np
import numpy.typing as npt

__all__ = [
    "solve", "solve_many", "solve_surface", "solve_surface_many", "influence_coefficients", "kernel_spectrum",
    "fft_friendly_length", "westergaard_element_pressure",
    "westergaard_contact_half_width", "flat_punch_element_pressure", "self_affine_profile", "von_meier", "clapp",
    "_panic_for_tests", "__version__",
]

__version__: str

def solve(
    heights: npt.NDArray[np.float64], dx: float, youngs_modulus: float, poisson: float, mean_pressure: float,
    periodic: bool, kernel: str, method: str, tol: float, max_iterations: int,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], int, float, bool]: ...
def solve_many(
    segments: npt.NDArray[np.float64], dx: float, youngs_moduli: npt.NDArray[np.float64], poisson: float,
    mean_pressure: float, periodic: bool, kernel: str, method: str, tol: float, max_iterations: int,
    threads: int | None = None, warm_start: bool = False, coarse_start: int | None = None,
    initial_pressure: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.uint64], npt.NDArray[np.float64],
           npt.NDArray[np.bool_]]: ...
def solve_surface(
    heights: npt.NDArray[np.float64], dx: float, dy: float, youngs_modulus: float, poisson: float,
    mean_pressure: float, periodic: bool, kernel: str, method: str, tol: float, max_iterations: int,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], int, float, bool]: ...
def solve_surface_many(
    tiles: npt.NDArray[np.float64], dx: float, dy: float, youngs_moduli: npt.NDArray[np.float64], poisson: float,
    mean_pressure: float, periodic: bool, kernel: str, method: str, tol: float, max_iterations: int,
    threads: int | None = None, warm_start: bool = False, initial_pressure: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.uint64], npt.NDArray[np.float64],
           npt.NDArray[np.bool_]]: ...
def influence_coefficients(n: int, dx: float, periodic: bool) -> npt.NDArray[np.float64]: ...
def kernel_spectrum(n: int, dx: float, kernel: str) -> npt.NDArray[np.float64]: ...
def fft_friendly_length(n: int) -> int: ...
def westergaard_element_pressure(
    x: npt.NDArray[np.float64], dx: float, amplitude: float, wavelength: float, plane_strain_modulus: float,
    mean_pressure: float,
) -> npt.NDArray[np.float64]: ...
def westergaard_contact_half_width(amplitude: float, wavelength: float, plane_strain_modulus: float,
                                   mean_pressure: float) -> float: ...
def flat_punch_element_pressure(x: npt.NDArray[np.float64], dx: float, width: float,
                                mean_pressure: float) -> npt.NDArray[np.float64]: ...
def self_affine_profile(n: int, length: float, hurst: float, rms_slope: float, cutoff_fraction: float,
                        seed: int) -> npt.NDArray[np.float64]: ...
def von_meier(heights: npt.NDArray[np.float64], dx: float, d_star: float) -> npt.NDArray[np.float64]: ...
def clapp(
    heights: npt.NDArray[np.float64], dx: float, youngs_modulus: float, poisson: float, mean_pressure: float,
    sub_profile: int, overlap: int, wrap: bool,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], int, int]: ...

# Test hook, not API: panics inside the Rust core (on a rayon thread, with the GIL released) so that
# tests can check a panic arrives as roadtex.errors.InternalError carrying `message`.
def _panic_for_tests(message: str) -> None: ...
