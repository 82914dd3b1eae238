"""The package runs where its wheels install (Linux, macOS, Windows): no POSIX-only call, no
hard-coded Unix path, text files read and written as UTF-8 whatever the locale, and the command's
messages survive a console that cannot spell a file's name."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "python" / "roadtex"

#: Module attributes that do not exist (or differ) on Windows.
POSIX_ONLY = {("os", "fork"), ("os", "forkpty"), ("os", "getloadavg"), ("os", "sched_getaffinity"), ("os", "getuid"),
              ("os", "geteuid"), ("os", "killpg"), ("os", "setsid"), ("os", "nice"), ("signal", "SIGKILL"),
              ("signal", "SIGHUP"), ("signal", "SIGALRM"), ("signal", "alarm"), ("multiprocessing", "set_start_method")}
POSIX_MODULES = {"resource", "fcntl", "termios", "pwd", "grp", "posix"}


def package_sources():
    for path in sorted(PACKAGE.rglob("*.py")):
        yield path, ast.parse(path.read_text(encoding="utf-8"))


def test_no_posix_only_calls_modules_or_paths() -> None:
    # a line marked "# portable:" says how it is guarded (a POSIX branch beside a Windows one, an
    # AttributeError caught): the marker names the guard, which a reviewer checks
    offenders = []
    for path, tree in package_sources():
        where = path.relative_to(PACKAGE)
        lines = path.read_text(encoding="utf-8").splitlines()
        for node in ast.walk(tree):
            if hasattr(node, "lineno") and "# portable:" in lines[node.lineno - 1]:
                continue
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and (node.value.id, node.attr) in POSIX_ONLY:
                offenders.append(f"{where}:{node.lineno} {node.value.id}.{node.attr}")
            elif isinstance(node, ast.Import | ast.ImportFrom):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
                offenders += [f"{where}:{node.lineno} import {n}" for n in names if n.split(".")[0] in POSIX_MODULES]
            elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.startswith(("/proc", "/tmp", "/dev/")):
                offenders.append(f"{where}:{node.lineno} path {node.value!r}")
    assert offenders == []


def test_text_files_are_read_and_written_as_utf8() -> None:
    # Path.read_text / write_text without an encoding use the locale's (cp1252 on Windows).
    offenders = []
    for path, tree in package_sources():
        for node in ast.walk(tree):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr in ("read_text", "write_text")
                    and not any(k.arg == "encoding" for k in node.keywords)):
                offenders.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {node.func.attr}() without encoding")
    assert offenders == []


def test_cli_output_naming_an_unspellable_file_survives_an_ascii_console(tmp_path: Path) -> None:
    # Windows writes redirected output in the locale's code page; `roadtex manifest` prints the
    # manifest's name on stdout, whose errors are strict: a name it cannot spell crashed the command
    # after its work was done.
    import roadtex

    (tmp_path / "survey").mkdir()
    roadtex.write_profile(roadtex.synthetic_pavement("dense_asphalt", length=0.2, dx=0.5e-3, seed=1),
                          tmp_path / "survey" / "run.csv")
    out = tmp_path / "relevé_été.csv"
    env = {**os.environ, "PYTHONIOENCODING": "ascii"}
    done = subprocess.run([sys.executable, "-m", "roadtex.cli", "manifest", str(tmp_path / "survey"), "--out", str(out)],
                          capture_output=True, env=env)
    assert "UnicodeEncodeError" not in done.stderr.decode("ascii", "replace")
    assert done.returncode == 0 and out.is_file()
    assert "relev\\xe9_\\xe9t\\xe9.csv" in done.stdout.decode("ascii"), done.stdout
