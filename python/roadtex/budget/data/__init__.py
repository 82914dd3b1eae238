"""Data shipped with :mod:`roadtex.budget`: ``sampling_calibration.csv`` (see :mod:`roadtex.budget.sampling`)."""
