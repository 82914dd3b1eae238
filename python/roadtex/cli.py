"""The ``roadtex`` command line."""

from __future__ import annotations

import argparse
import logging
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any


def refused_rubber(command: str, moduli: list[float], pressure: float, remedy: str = "") -> bool:
    """Prints one error line for each modulus and the pressure (MPa) outside the plausible ranges
    of tyre rubber (usually a unit mistake); True when any was refused."""
    from roadtex._checks import PLAUSIBLE_MODULUS, PLAUSIBLE_PRESSURE, implausible_parameter

    checks = [("--moduli", e, PLAUSIBLE_MODULUS, "tyre rubber's Young's modulus") for e in moduli]
    checks.append(("--pressure", pressure, PLAUSIBLE_PRESSURE, "a tyre's mean contact pressure"))
    refused = [(flag, value, plausible, what) for flag, value, plausible, what in checks
               if implausible_parameter(value * 1e6, flag, plausible) is not None]
    for flag, value, (low, high), what in refused:
        print(f"roadtex {command}: error: {flag} {value:g} MPa is outside the plausible range of {what} "
              f"({low / 1e6:g} to {high / 1e6:g} MPa). {flag} is in MPa (e.g. --moduli 1 2.5 10 --pressure 0.2)."
              f"{remedy}", file=sys.stderr)
    return bool(refused)


def demo(args: argparse.Namespace) -> int:
    """``roadtex demo``: the real pipeline on the built-in archive (or a given manifest), then the report."""
    from roadtex.demo import run_demo

    if refused_rubber("demo", args.moduli, args.pressure):   # as process refuses them (the demo has no override)
        return 2
    return run_demo(Path(args.out), runs=args.runs, run_length=args.run_length, moduli_mpa=args.moduli,
                    pressure_mpa=args.pressure, manifest_path=args.manifest, benchmark=args.benchmark, quiet=args.quiet)


def report_command(args: argparse.Namespace) -> int:
    """``roadtex report RESULTS_DIR``: the HTML report and figures of a processed archive."""
    from roadtex.report import build_report

    try:
        report = build_report(args.results, out_dir=args.out, benchmark=args.benchmark)
    except (FileNotFoundError, ValueError) as exc:
        print(f"roadtex report: error: {exc}", file=sys.stderr)
        return 2
    print(f"roadtex report: {len(report.figures)} figures -> {report.html}")
    return 0


class CurrentStderrHandler(logging.StreamHandler):
    """A log handler that writes to whatever ``sys.stderr`` is when a record comes (``main`` may be
    called again in one process with stderr replaced, as tests do)."""

    @property  # type: ignore[override]
    def stream(self) -> object:
        return sys.stderr

    @stream.setter
    def stream(self, value: object) -> None:
        pass


def process_command(args: argparse.Namespace) -> int:
    """``roadtex process MANIFEST --out DIR``: the bulk job."""
    import warnings

    from roadtex.archive import ArchiveWriteError, ManifestError, ProcessingOptions, process
    from roadtex.errors import ImplausibleParameterWarning, JobInterrupted, MissingDependencyError
    from roadtex.profiles.plausibility import PLAUSIBLE_MAX_DX
    from roadtex.profiles.readers.text import bare_interval_unit

    if args.quiet:
        # roadtex's one line per run, on a handler of its own: a root handler would also print the
        # INFO lines of other libraries (Dask's scheduler and workers, some 40 per job)
        log = logging.getLogger("roadtex")
        log.setLevel(logging.INFO)
        if not any(isinstance(h, CurrentStderrHandler) for h in log.handlers):
            handler = CurrentStderrHandler()
            handler.setFormatter(logging.Formatter("%(asctime)s %(name)s %(message)s"))
            log.addHandler(handler)
    if not args.allow_implausible:
        refused = refused_rubber("process", args.moduli, args.pressure, " --allow-implausible solves it anyway.")
        # --input-dx's metres are stated by --distance-unit m (a 1 cm survey, processed with a
        # CoarseSamplingWarning per file); --dx is the job's own resampling, always judged
        input_dx_stated = bare_interval_unit(args.distance_unit) is not None
        coarse = [(flag, value) for flag, value in (("--dx", args.dx), ("--input-dx", args.input_dx))
                  if value is not None and value > PLAUSIBLE_MAX_DX and not (flag == "--input-dx" and input_dx_stated)]
        for flag, value in coarse:
            stating = " --distance-unit m states that it is right (a coarse survey);" if flag == "--input-dx" else ""
            print(f"roadtex process: error: {flag} {value:g} m is coarser than any texture profile's sampling (at "
                  f"most {PLAUSIBLE_MAX_DX:g} m). {flag} is in metres (e.g. {flag} 0.5e-3 for 0.5 mm);{stating} "
                  "--allow-implausible solves it anyway.", file=sys.stderr)
        if refused or coarse:
            return 2
    reader_defaults = {"distance_unit": args.distance_unit, "height_unit": args.height_unit,
                       "delimiter": args.delimiter, "decimal": args.decimal, "dx": args.input_dx,
                       "dropout_value": args.dropout_value}
    try:
        options = ProcessingOptions(
            youngs_moduli=tuple(e * 1e6 for e in args.moduli), mean_pressure=args.pressure * 1e6,
            poisson=args.poisson, segment_length=args.segment_length, segment_overlap=args.overlap,
            dx=args.dx, spike_alpha=None if args.spike_alpha <= 0 else args.spike_alpha,
            mpd_spike_alpha=None if args.mpd_spike_alpha <= 0 else args.mpd_spike_alpha, tol=args.tol,
            refine=args.refine, interpolant=args.interpolant, sampling_correction=args.sampling_correction,
            error_budget_db=error_budget(args.error_budget),
            band_kind=args.bands, band_method=args.band_method, speed_kmh=args.speed, keep_profiles=args.keep_profiles,
            allow_implausible=args.allow_implausible,
            section_length=args.section_length, etd_edition=args.etd_edition,
            reader_defaults={k: v for k, v in reader_defaults.items() if v is not None})
        with warnings.catch_warnings():
            # the plausibility of E and P was settled above (--allow-implausible)
            warnings.simplefilter("ignore", ImplausibleParameterWarning)
            summary = process(args.manifest, args.out, options, engine=args.engine, scheduler=args.scheduler,
                              workers=args.workers, threads=args.threads, quiet=args.quiet, force=args.force,
                              retry_failed=args.retry_failed)
    except (ManifestError, ArchiveWriteError, MissingDependencyError, ValueError) as exc:
        print(f"roadtex process: error: {exc}", file=sys.stderr)
        return 2
    except JobInterrupted as stop:
        print(f"roadtex process: {stop}", file=sys.stderr)
        return 130   # 128 + SIGINT, as shells report a command stopped by Ctrl-C
    print(f"roadtex process: {summary}")
    width = max((len(name) for name in summary.tables), default=0)
    for name, path in summary.tables.items():
        print(f"  {name:<{width}} {path}")
    if summary.failed_on_record:
        print(f"roadtex process: {summary.failed_on_record} run(s) failed, by cause (all of them in "
              f"{summary.tables.get('errors')}):", file=sys.stderr)
        for line in failure_causes(summary.tables.get("errors")):
            print(f"  {line}", file=sys.stderr)
    return 1 if summary.failed_on_record else 0


def failure_causes(errors_table: Path | None, shown: int = 10) -> list[str]:
    """The failed runs of errors.parquet grouped by cause (stage, error type and message, the file's
    name and the numbers in the message aside: 'the run is 0.3 m long' and '0.2 m long' are one
    cause), most frequent first: one line each with the count and one example file's message."""
    import re

    import polars as pl

    if errors_table is None or not Path(errors_table).is_file():
        return []
    errors = pl.read_parquet(errors_table)
    groups: dict[tuple[str, str, str], list[dict[str, str]]] = {}
    for row in errors.iter_rows(named=True):
        message = str(row["message"] or "")
        name = Path(str(row["path"] or "")).name
        generic = re.sub(r"[-+]?\d[\d.,eE+-]*", "#", message.replace(name, "FILE") if name else message)
        groups.setdefault((str(row["stage"]), str(row["error_type"]), generic), []).append(row)
    ordered = sorted(groups.items(), key=lambda item: -len(item[1]))
    lines = [f"{len(rows)} run(s), {stage} ({kind}), e.g. {rows[0]['message']}"
             for (stage, kind, _), rows in ordered[:shown]]
    if len(ordered) > shown:
        lines.append(f"... and {len(ordered) - shown} more cause(s)")
    return lines


def error_budget(text: str) -> float | None:
    """--error-budget: a positive number of dB, or 'off'."""
    if text.strip().lower() in ("off", "none", "no"):
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"--error-budget must be a positive number of dB (e.g. 0.2) or 'off', got {text!r}")
    return value


def manifest_command(args: argparse.Namespace) -> int:
    """``roadtex manifest FOLDER --out manifest.csv``: lists a folder's profile files as a manifest."""
    import polars as pl

    from roadtex.archive import ManifestError, build_manifest
    from roadtex.archive.manifest import job_output_folders, unlisted_files

    try:
        table = build_manifest(args.folder, recursive=not args.no_recursive)
    except ManifestError as exc:
        print(f"roadtex manifest: error: {exc}", file=sys.stderr)
        return 2
    # paths relative to the manifest's folder (where roadtex process takes them from): the folder and
    # its manifest can be moved, or sent, together
    home = Path(args.out).resolve().parent
    written = table.with_columns(pl.Series("path", [relative_path(path, home) for path in table["path"]]))
    written.drop([c for c in written.columns if written[c].null_count() == written.height]).write_csv(args.out)
    print(f"roadtex manifest: {table.height} runs -> {args.out}")
    outputs = job_output_folders(Path(args.folder), not args.no_recursive)
    if outputs:
        names = ", ".join(str(folder.relative_to(args.folder)) for folder in outputs[:5])
        print(f"roadtex manifest: skipped {len(outputs)} folder(s) holding a roadtex job's outputs (parameters.json, "
              f"status files), not survey data: {names}{' ...' if len(outputs) > 5 else ''}")
    skipped = unlisted_files(args.folder, recursive=not args.no_recursive)
    if skipped:
        print(f"roadtex manifest: warning: {len(skipped)} file(s) of the folder are not listed:", file=sys.stderr)
        for note in skipped[:10]:
            print(f"  {note}", file=sys.stderr)
        if len(skipped) > 10:
            print(f"  ... and {len(skipped) - 10} more", file=sys.stderr)
    surfaces = sum(fmt == "surface" for fmt in table["format"])
    if surfaces:
        print(f"roadtex manifest: {surfaces} of them 3-D surfaces (format 'surface'; dx, dy in m and units as "
              "manifest columns where the file has none)")
    problems = [problem for path, fmt in zip(table["path"], table["format"])
                if fmt is None or fmt == "surface"
                for problem in [read_problem(path, surface=fmt == "surface")] if problem is not None]
    if problems:
        print(f"roadtex manifest: warning: {len(problems)} of the files cannot be read as they are; they are listed, "
              "and roadtex process records them as failed unless the manifest gives what they need:", file=sys.stderr)
        for problem in problems[:10]:
            print(f"  {problem}", file=sys.stderr)
        if len(problems) > 10:
            print(f"  ... and {len(problems) - 10} more", file=sys.stderr)
    return 0


def relative_path(path: str, folder: Path) -> str:
    """``path`` relative to ``folder`` with forward slashes (a spreadsheet's and every system's),
    or as it is where there is no relative path (another drive)."""
    import os

    try:
        return Path(os.path.relpath(path, folder)).as_posix()
    except ValueError:
        return path


def read_problem(path: str, *, surface: bool = False) -> str | None:
    """Why a profile file (or with ``surface`` a 3-D surface file) cannot be read with the default
    options (the reader's message names it); None when it reads."""
    import warnings

    from roadtex.profiles.readers import read_profile
    from roadtex.surfaces.readers import read_surface

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if surface:
                read_surface(path)
            else:
                read_profile(path)
    except Exception as exc:  # noqa: BLE001 - any reader failure is reported, not raised
        name = Path(path).name   # the readers' own errors name it; numpy's MemoryError and the like do not
        message = str(exc) or type(exc).__name__
        return message if name in message else f"{name}: {type(exc).__name__}: {message}"
    return None if surface else f"{Path(path).name}: read now"   # a profile listed unreadable reads now


def _add_processing_arguments(parser: argparse.ArgumentParser) -> None:
    from roadtex.archive import ProcessingOptions

    defaults = ProcessingOptions()
    moduli = " ".join(f"{e / 1e6:g}" for e in defaults.youngs_moduli)
    parser.add_argument("--moduli", type=float, nargs="+", default=[e / 1e6 for e in defaults.youngs_moduli],
                        metavar="MPA", help=f"rubber Young's moduli E in MPa (default {moduli}; "
                                            "outside 0.1 to 100 MPa refused unless --allow-implausible)")
    parser.add_argument("--pressure", type=float, default=defaults.mean_pressure / 1e6, metavar="MPA",
                        help=f"mean contact pressure P in MPa (default {defaults.mean_pressure / 1e6:g}; "
                             "outside 0.02 to 3 MPa refused unless --allow-implausible)")
    parser.add_argument("--allow-implausible", action="store_true",
                        help="solve for E and P outside the plausible ranges, with --dx, --input-dx above 5 mm, "
                             "and process files whose heights or interval cannot be road texture in metres "
                             "(they are usually unit mistakes; such runs are refused without it). Files whose "
                             "distance unit is certain (OpenCRG, a unit in the header, --distance-unit) are "
                             "processed above 5 mm without it, with a warning, their unresolved bands not reported")
    parser.add_argument("--poisson", type=float, default=defaults.poisson, help="rubber Poisson ratio (default 0.5)")
    parser.add_argument("--segment-length", type=float, default=defaults.segment_length, metavar="M",
                        help="segment length in m for the periodic contact model (default 0.5)")
    parser.add_argument("--section-length", type=float, default=defaults.section_length, metavar="M",
                        help="length in m of the reporting sections of line runs (sections.parquet: MPD, ETD, Rq, "
                             "Rsk, Rku, band levels per section; default 10)")
    parser.add_argument("--etd-edition", choices=("2019", "1997"), default=defaults.etd_edition,
                        help="ISO 13473-1 edition of the ETD in sections.parquet: 2019 (1.1 MPD, default) or "
                             "1997 (0.2 mm + 0.8 MPD)")
    parser.add_argument("--overlap", type=float, default=defaults.segment_overlap, metavar="M",
                        help="overlap of consecutive segments in m (default 0)")
    parser.add_argument("--dx", type=float, default=None, metavar="M",
                        help="average runs sampled more finely down to this interval in m before solving (default: "
                             "each run on its own readings, or coarser where its pilot chooses; a run sampled more "
                             "coarsely keeps its own; above 5 mm refused unless --allow-implausible)")
    parser.add_argument("--spike-alpha", type=float, default=defaults.spike_alpha,
                        help="spike criterion before contact and spectra: a reading alpha x 0.5 mm from the median "
                             "within 0.5 mm is a spike (default 3, ISO 13473-1's alpha; 0 turns it off)")
    parser.add_argument("--mpd-spike-alpha", type=float, default=defaults.mpd_spike_alpha,
                        help="spike criterion alpha of the ISO 13473-1 MPD (default 3; 0 turns it off)")
    parser.add_argument("--error-budget", default=f"{defaults.error_budget_db:g}", metavar="DB",
                        help=f"largest numerical error in dB allowed on any level in the tyre/road noise bands; a pilot "
                             f"picks the cheapest sampling and tolerance within it (default {defaults.error_budget_db:g}; "
                             "'off' switches it off)")
    parser.add_argument("--tol", type=float, default=None,
                        help="solver tolerance (default: chosen by the error budget; 1e-6 with --error-budget off)")
    parser.add_argument("--refine", type=int, default=None, metavar="K",
                        help="solve the contact model on a grid K times finer than the data's, the readings joined "
                             "by --interpolant (default: chosen by the error budget; 1 with --error-budget off); "
                             "still estimated")
    parser.add_argument("--interpolant", choices=["linear", "pchip", "bandlimited"], default=defaults.interpolant,
                        help="the road between readings on the model's finer grid (default pchip: monotone cubics)")
    parser.add_argument("--sampling-correction", action="store_true",
                        help="subtract from the enveloped levels the bias the data's sampling causes where the "
                             "calibration on real 0.0375 mm data shows a systematic one (e.g. -0.9 dB at 2.5 mm for "
                             "1 mm data); bands.parquet states it and its uncertainty (default: off)")
    parser.add_argument("--bands", choices=["third_octave", "octave"], default=defaults.band_kind,
                        help="band kind of the spectra (default third_octave)")
    parser.add_argument("--band-method", choices=["dft", "filter"], default=defaults.band_method,
                        help="band levels by exact DFT sums (default) or by IEC 61260 class-1 band filters "
                             "(ISO 13473-4:2024's normative method)")
    parser.add_argument("--speed", type=float, default=None, metavar="KMH",
                        help="vehicle speed in km/h for band frequencies when the manifest has none")
    reading = parser.add_argument_group("reading files (defaults for every run; manifest columns of the same "
                                        "names override them per run)")
    reading.add_argument("--distance-unit", default=None, metavar="UNIT",
                         help="unit of the distance column of files whose header states none (m, mm, um); "
                              "a unit in a header is kept")
    reading.add_argument("--height-unit", default=None, metavar="UNIT",
                         help="unit of the height column of files whose header states none (m, mm, um); "
                              "a unit in a header is kept")
    reading.add_argument("--delimiter", default=None, help="column delimiter of text files (default: sniffed)")
    reading.add_argument("--decimal", default=None, choices=[".", ","],
                         help="decimal mark of text files (default: sniffed; ',' for European exports)")
    reading.add_argument("--dropout-value", type=float, default=None, metavar="VALUE",
                         help="the number text and CAPTIF files write for a missing reading (in the file's "
                              "height unit, e.g. -9999): read as a drop-out")
    reading.add_argument("--input-dx", type=float, default=None, metavar="M",
                         help="sampling interval in m of heights-only files (.npy, one-column text); files with "
                              "distances keep their own")
    parser.add_argument("--keep-profiles", action="store_true",
                        help="also write the enveloped profiles and pressures (large)")
    parser.add_argument("--engine", choices=["local", "dask"], default="local",
                        help="local (default) or dask (distributed over Dask workers)")
    parser.add_argument("--scheduler", default=None,
                        help="Dask scheduler address (default: start a local cluster)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes of a local Dask cluster (default 2)")
    parser.add_argument("--threads", type=int, default=None,
                        help="Rust threads per run (default: the job shares the cores between its runs in flight)")
    parser.add_argument("--force", action="store_true", help="recompute runs that are already done")
    parser.add_argument("--retry-failed", action="store_true",
                        help="process again the runs that failed before (they stay on record until retried)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar; one log line per run")


def show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int, file: object = None,
                 line: str | None = None) -> None:
    """Warnings as a command-line tool prints them: one line, no Python file and line number."""
    print(f"roadtex: warning: {message}", file=sys.stderr)


def unrecognized(parser: argparse.ArgumentParser, unknown: list[str]) -> None:
    """Exits as argparse does (status 2), with the sub-command's usage (not the top level's, which
    says nothing of its options) and, for each unknown option, the closest known one."""
    import difflib

    known = [option for action in parser._actions for option in action.option_strings]
    hints = []
    for arg in unknown:
        if arg.startswith("-"):
            close = difflib.get_close_matches(arg.split("=", 1)[0], known, n=1, cutoff=0.6)
            if close:
                hints.append(f"{arg}: did you mean {close[0]}?")
    parser.error(f"unrecognized arguments: {' '.join(unknown)}{' (' + '; '.join(hints) + ')' if hints else ''}")


class CommandParser(argparse.ArgumentParser):
    """A sub-command's parser whose arguments ``complete`` adds when it is first used (parsed, or
    its help or usage formatted): ``process``'s defaults come from ProcessingOptions, whose import
    loads the whole job (polars, scipy), which ``roadtex --help`` and ``--version`` never need."""

    def __init__(self, *args: Any, complete: Callable[[argparse.ArgumentParser], None] | None = None,
                 **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._complete = complete

    def completed(self) -> CommandParser:
        """This parser with all its arguments (added now if they were not yet)."""
        if self._complete is not None:
            complete, self._complete = self._complete, None
            complete(self)
        return self

    def parse_known_args(self, args: Any = None, namespace: Any = None) -> Any:
        return super(CommandParser, self.completed()).parse_known_args(args, namespace)

    def format_help(self) -> str:
        return super(CommandParser, self.completed()).format_help()

    def format_usage(self) -> str:
        return super(CommandParser, self.completed()).format_usage()


def build_parser() -> argparse.ArgumentParser:
    """The ``roadtex`` command's parser, with its sub-commands (the docs' CLI reference renders it)."""
    from roadtex._core import __version__

    # no abbreviations: '--pres 0.3' must not be taken silently as --pressure (nor a later option
    # sharing the prefix break an old command line)
    parser = argparse.ArgumentParser(prog="roadtex", description="Tyre/road contact and texture envelopment.",
                                     allow_abbrev=False)
    parser.add_argument("-V", "--version", action="version", version=f"roadtex {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=CommandParser)
    d = commands.add_parser("demo", help="the main job on the built-in synthetic archive: process, then report",
                            allow_abbrev=False)
    d.add_argument("--out", default="roadtex-output", help="output folder (default roadtex-output)")
    d.add_argument("--manifest", default=None, help="process this archive instead of the built-in one")
    d.add_argument("--runs", type=int, default=2, help="runs per pavement type in the built-in archive (default 2)")
    d.add_argument("--run-length", type=float, default=4.0, metavar="M", help="metres per built-in run (default 4)")
    d.add_argument("--moduli", type=float, nargs="+", default=[1.0, 2.0, 5.0, 10.0], metavar="MPA",
                   help="Young's moduli in MPa (default 1 2 5 10)")
    d.add_argument("--pressure", type=float, default=0.2, metavar="MPA", help="mean pressure in MPa (default 0.2)")
    d.add_argument("--benchmark", default=None, help="speed_vs_error.py --json rows for the speed figure")
    d.add_argument("--quiet", action="store_true", help="no progress bar")
    d.set_defaults(run=demo)
    p = commands.add_parser("process", help="process an archive: manifest in, Parquet tables out (resumable)",
                            allow_abbrev=False, complete=_add_processing_arguments)
    p.add_argument("manifest", help="manifest file (CSV or Parquet) listing the runs")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(run=process_command)
    r = commands.add_parser("report", help="HTML report and figures of a processed archive", allow_abbrev=False)
    r.add_argument("results", help="the output folder of roadtex process")
    r.add_argument("--out", default=None, help="report folder (default RESULTS/report)")
    r.add_argument("--benchmark", default=None, help="speed_vs_error.py --json rows for the speed figure")
    r.set_defaults(run=report_command)
    m = commands.add_parser("manifest", help="list a folder's profile and 3-D surface files as a manifest CSV", allow_abbrev=False)
    m.add_argument("folder", help="folder with profile and surface files (surfaces get format 'surface')")
    m.add_argument("--out", default="manifest.csv", help="manifest file to write (default manifest.csv)")
    m.add_argument("--no-recursive", action="store_true", help="do not descend into sub-folders")
    m.set_defaults(run=manifest_command)
    return parser


def main(argv: list[str] | None = None) -> int:
    import warnings

    warnings.showwarning = show_warning
    # A console or pipe whose encoding cannot spell a file's name (Windows writes redirected output in
    # the locale's code page, cp1252, not UTF-8) would turn a clear message into UnicodeEncodeError.
    for stream in (sys.stdout, sys.stderr):
        if hasattr(stream, "reconfigure"):
            stream.reconfigure(errors="backslashreplace")
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        unrecognized(commands.choices[args.command], unknown)
    try:
        return args.run(args)
    except KeyboardInterrupt:   # Ctrl-C outside a job's runs (process says how many runs were done)
        print(f"roadtex {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
