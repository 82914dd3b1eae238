"""The report of a processed archive: the seed's figures and tables in one HTML file, drawn from
the job's outputs alone (:mod:`~roadtex.report.data`), by figure family
(:mod:`~roadtex.report.profile_figures`, :mod:`~roadtex.report.spectra_figures`) and assembled in
:mod:`~roadtex.report.document`."""

from roadtex.report.document import FIGURES, SEED_FIGURES, Report, build_report, draw_figures, run_table
from roadtex.report.spectra_figures import octave_table

__all__ = ["FIGURES", "SEED_FIGURES", "Report", "build_report", "draw_figures", "octave_table", "run_table"]
