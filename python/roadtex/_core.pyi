"""Type stubs of the Rust extension; the documented API is in roadtex.contact and friends."""

import numpy as np
import numpy.typing as npt

__version__: str

def solve(
    heights: npt.NDArray[np.float64], dx: float, youngs_modulus: float, poisson: float, mean_pressure: float,
    periodic: bool, kernel: str, method: str, tol: float, max_iterations: int,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], int, float, bool]: ...
def solve_many(
    segments: npt.NDArray[np.float64], dx: float, youngs_moduli: npt.NDArray[np.float64], poisson: float,
    mean_pressure: float, periodic: bool, kernel: str, method: str, tol: float, max_iterations: int,
    threads: int | None = None, warm_start: bool = False,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.uint64], npt.NDArray[np.float64],
           npt.NDArray[np.bool_]]: ...
def influence_coefficients(n: int, dx: float, periodic: bool) -> npt.NDArray[np.float64]: ...
def kernel_spectrum(n: int, dx: float, kernel: str) -> npt.NDArray[np.float64]: ...
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
