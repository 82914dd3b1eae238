"""The error budget: how finely each run must be modelled for its levels to stay within a given
numerical error, and what that costs.

- :mod:`roadtex.budget.sizes`: FFT-friendly (5-smooth) point counts;
- :mod:`roadtex.budget.noise`: the default budget and the tyre/road noise bands it applies to;
- :mod:`roadtex.budget.study`: the pilot's reference, levels converging with the model grid on pilot segments;
- :mod:`roadtex.budget.candidates`: :func:`convergence_study`, the candidates' levels against the reference;
- :mod:`roadtex.budget.pilot`: :func:`choose_setting`, the cheapest setting within the budget;
- :mod:`roadtex.budget.areal`: the error estimates of surface runs (an areal pilot on a few tiles).
- :mod:`roadtex.budget.sampling`: what a run's sampling cannot tell of its contact levels, apart from
  the numerical error (calibrated on real fine profiles by :mod:`roadtex.budget.sampling_calibration`).
"""

from roadtex.budget.candidates import convergence_study
from roadtex.budget.noise import DEFAULT_ERROR_BUDGET_DB, NOISE_FREQUENCY_RANGE, NOISE_SPEED_RANGE_KMH, budget_bands
from roadtex.budget.pilot import BudgetChoice, choose_setting
from roadtex.budget.sizes import five_smooth_ladder, is_five_smooth, next_five_smooth, previous_five_smooth
from roadtex.budget.study import REFERENCE_TOL

__all__ = ["DEFAULT_ERROR_BUDGET_DB", "NOISE_FREQUENCY_RANGE", "NOISE_SPEED_RANGE_KMH", "budget_bands",
           "five_smooth_ladder", "is_five_smooth", "next_five_smooth", "previous_five_smooth", "REFERENCE_TOL",
           "convergence_study", "BudgetChoice", "choose_setting"]
