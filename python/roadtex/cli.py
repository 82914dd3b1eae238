"""The ``roadtex`` command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def demo(args: argparse.Namespace) -> int:
    """``roadtex demo``: the real pipeline on the built-in archive (or a given manifest), then the report."""
    from roadtex.demo import run_demo

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


def process_command(args: argparse.Namespace) -> int:
    """``roadtex process MANIFEST --out DIR``: the bulk job."""
    import logging

    from roadtex.archive import ArchiveWriteError, ManifestError, ProcessingOptions, process

    if args.quiet:
        logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    try:
        options = ProcessingOptions(
            youngs_moduli=tuple(e * 1e6 for e in args.moduli), mean_pressure=args.pressure * 1e6,
            poisson=args.poisson, segment_length=args.segment_length, segment_overlap=args.overlap,
            dx=args.dx, spike_alpha=args.spike_alpha,
            mpd_spike_alpha=None if args.mpd_spike_alpha <= 0 else args.mpd_spike_alpha, tol=args.tol,
            band_kind=args.bands, speed_kmh=args.speed, keep_profiles=args.keep_profiles)
        summary = process(args.manifest, args.out, options, engine=args.engine, scheduler=args.scheduler,
                          workers=args.workers, threads=args.threads, quiet=args.quiet, force=args.force)
    except (ManifestError, ArchiveWriteError, ValueError) as exc:
        print(f"roadtex process: error: {exc}", file=sys.stderr)
        return 2
    print(f"roadtex process: {summary}")
    for name, path in summary.tables.items():
        print(f"  {name:<11} {path}")
    return 1 if summary.failed else 0


def manifest_command(args: argparse.Namespace) -> int:
    """``roadtex manifest FOLDER --out manifest.csv``: lists a folder's profile files as a manifest."""
    from roadtex.archive import ManifestError, build_manifest

    try:
        table = build_manifest(args.folder, recursive=not args.no_recursive)
    except ManifestError as exc:
        print(f"roadtex manifest: error: {exc}", file=sys.stderr)
        return 2
    table.drop([c for c in table.columns if table[c].null_count() == table.height]).write_csv(args.out)
    print(f"roadtex manifest: {table.height} runs -> {args.out}")
    return 0


def _add_processing_arguments(parser: argparse.ArgumentParser) -> None:
    from roadtex.archive import ProcessingOptions

    defaults = ProcessingOptions()
    parser.add_argument("--moduli", type=float, nargs="+", default=[e / 1e6 for e in defaults.youngs_moduli],
                        metavar="MPA", help="rubber Young's moduli E in MPa (default 1 2 5 10)")
    parser.add_argument("--pressure", type=float, default=defaults.mean_pressure / 1e6, metavar="MPA",
                        help="mean contact pressure P in MPa (default 0.2)")
    parser.add_argument("--poisson", type=float, default=defaults.poisson, help="rubber Poisson ratio (default 0.5)")
    parser.add_argument("--segment-length", type=float, default=defaults.segment_length, metavar="M",
                        help="segment length in m for the periodic contact model (default 0.5)")
    parser.add_argument("--overlap", type=float, default=defaults.segment_overlap, metavar="M",
                        help="overlap of consecutive segments in m (default 0)")
    parser.add_argument("--dx", type=float, default=None, metavar="M",
                        help="resample every run to this sampling interval in m (default: keep the file's)")
    parser.add_argument("--spike-alpha", type=float, default=defaults.spike_alpha,
                        help="spike criterion alpha of the conditioning for the contact model "
                             "(default: no spike removal)")
    parser.add_argument("--mpd-spike-alpha", type=float, default=defaults.mpd_spike_alpha,
                        help="spike criterion alpha of the ISO 13473-1 MPD (default 3; 0 turns it off)")
    parser.add_argument("--tol", type=float, default=defaults.tol, help="solver tolerance (default 1e-6)")
    parser.add_argument("--bands", choices=["third_octave", "octave"], default=defaults.band_kind,
                        help="band kind of the spectra (default third_octave)")
    parser.add_argument("--speed", type=float, default=None, metavar="KMH",
                        help="vehicle speed in km/h for band frequencies when the manifest has none")
    parser.add_argument("--keep-profiles", action="store_true",
                        help="also write the enveloped profiles and pressures (large)")
    parser.add_argument("--engine", choices=["local", "dask"], default="local",
                        help="local (default) or dask (distributed over Dask workers)")
    parser.add_argument("--scheduler", default=None,
                        help="Dask scheduler address (default: start a local cluster)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes of a local Dask cluster (default 2)")
    parser.add_argument("--threads", type=int, default=None, help="Rust threads per run (default: all cores)")
    parser.add_argument("--force", action="store_true", help="recompute runs that are already done")
    parser.add_argument("--quiet", action="store_true", help="no progress bar; one log line per run")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="roadtex", description="Tyre/road contact and texture envelopment.")
    commands = parser.add_subparsers(dest="command", required=True)
    d = commands.add_parser("demo", help="the main job on the built-in synthetic archive: process, then report")
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
    p = commands.add_parser("process", help="process an archive: manifest in, Parquet tables out (resumable)")
    p.add_argument("manifest", help="manifest file (CSV or Parquet) listing the runs")
    p.add_argument("--out", required=True, help="output folder")
    _add_processing_arguments(p)
    p.set_defaults(run=process_command)
    r = commands.add_parser("report", help="HTML report and figures of a processed archive")
    r.add_argument("results", help="the output folder of roadtex process")
    r.add_argument("--out", default=None, help="report folder (default RESULTS/report)")
    r.add_argument("--benchmark", default=None, help="speed_vs_error.py --json rows for the speed figure")
    r.set_defaults(run=report_command)
    m = commands.add_parser("manifest", help="list a folder's profile files as a manifest CSV")
    m.add_argument("folder", help="folder with profile files")
    m.add_argument("--out", default="manifest.csv", help="manifest file to write (default manifest.csv)")
    m.add_argument("--no-recursive", action="store_true", help="do not descend into sub-folders")
    m.set_defaults(run=manifest_command)
    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
