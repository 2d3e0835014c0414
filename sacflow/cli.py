"""Command line: ``sacflow run``, ``sacflow validate``, ``sacflow schema``.

A thin layer over :mod:`sacflow.storage.case_file` and :mod:`sacflow.runner`. Mistakes in a case are
printed as ``error: <message>`` with exit code 2, failed runs with exit code 1; never a traceback.
Before any work, the ``SACFLOW_*`` environment variables are checked
(:mod:`sacflow.machine.environment`)
and the ``--out`` folder is checked for writing (:mod:`sacflow.storage.output_dir`).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from sacflow.compare.command import add_compare_command
from sacflow.config.schema import Case, case_json_schema
from sacflow.errors import ConfigError, InputError, SacflowError
from sacflow.storage.case_file import load_case

__all__ = ["main"]

EXIT_RUN_FAILED = 1
EXIT_CONFIG = 2
EXIT_INTERRUPTED = 130
#: Exit code of a command whose reader went away (``sacflow schema | head``): 128 + SIGPIPE,
#: as a command killed by the signal would give.
EXIT_BROKEN_PIPE = 141


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``sacflow`` command; returns the exit code."""
    args = _parser().parse_args(argv)
    try:
        _check_before_work(args)
        return args.handler(args)
    except InputError as exc:
        _error(exc)
        return EXIT_CONFIG
    except BrokenPipeError:  # the reader has what it wanted: no message, no flush at exit
        with contextlib.suppress(OSError, ValueError):  # stdout may be no file (in tests)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except (SacflowError, OSError) as exc:
        _error(exc)
        return EXIT_RUN_FAILED
    except MemoryError:  # an allocation the memory check did not foresee (another process's)
        _error("out of memory: the machine could not give the run an array; the completed "
               "steps are kept (run again to resume), or use fewer cells (grid.nx, grid.ny, "
               "grid.nz) or a machine with more memory")
        return EXIT_RUN_FAILED
    except KeyboardInterrupt:
        _error("interrupted; the completed steps are kept, run again to resume")
        return EXIT_INTERRUPTED


#: Commands that compute (or check a case for computing): the SACFLOW_* variables are read
#: before they start.
_ENVIRONMENT_COMMANDS = ("run", "campaign", "validate", "cache")


def _check_before_work(args: argparse.Namespace) -> None:
    """Check the environment variables and the ``--out`` folder before any work.

    A bad ``SACFLOW_*`` value or an ``--out`` that is a file, lies under a file or cannot be
    created or written in is a :class:`ConfigError` naming it (:mod:`sacflow.machine.environment`,
    :mod:`sacflow.storage.output_dir`), not a failure after the first cases have run. Nothing is
    created
    here: the folder is made when the first file is written.
    """
    from sacflow.machine.environment import check_environment
    from sacflow.storage.output_dir import COMMAND_LINE, check_output_dir

    if args.command in _ENVIRONMENT_COMMANDS:
        check_environment()
    if isinstance(getattr(args, "out", None), Path):
        check_output_dir(args.out, COMMAND_LINE)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sacflow", description="Semi-analytical elastic-plastic contact runs."
    )
    commands = parser.add_subparsers(dest="command", required=True)

    run = commands.add_parser("run", help="run one or more cases, one netCDF file per case")
    _add_case_arguments(run)
    run.add_argument("--out", type=Path, default=Path("runs"), help="output folder (runs/)")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument(
        "--restart", action="store_true",
        help="recompute this case from its first step, replacing its stored steps",
    )  # fmt: skip
    run.add_argument(
        "--overwrite", action="store_true",
        help="replace a run of another case stored under the same name (never done otherwise)",
    )  # fmt: skip
    run.set_defaults(handler=_run)

    validate = commands.add_parser("validate", help="check cases and print their Hertz scales")
    _add_case_arguments(validate)
    validate.set_defaults(handler=_validate)

    campaign = commands.add_parser("campaign", help="run a parametric study with dask")
    campaign.add_argument("campaign", type=Path, metavar="CAMPAIGN", help="campaign file")
    campaign.add_argument("--out", type=Path, default=Path("runs"), help="output folder (runs/)")
    campaign.add_argument("--workers", type=int, metavar="N", help="local workers (default: cores)")
    campaign.add_argument("--scheduler", metavar="ADDRESS", help="dask scheduler, tcp://host:8786")
    campaign.add_argument(
        "--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
        help="override a field of the base case, e.g. --set grid.nz=8",
    )  # fmt: skip
    campaign.add_argument("--no-progress", action="store_true", help="no progress bar")
    campaign.add_argument(
        "--overwrite", action="store_true",
        help="replace runs of other cases stored under a case's name (never done otherwise)",
    )  # fmt: skip
    campaign.set_defaults(handler=_campaign)

    info = commands.add_parser("info", help="say what is stored in run files (one look each)")
    info.add_argument("runs", nargs="+", type=Path, metavar="RUN", help="run file(s) <name>.nc")
    info.set_defaults(handler=_info)

    add_compare_command(commands)  # sacflow compare STAGE RUN.nc ... (sacflow.compare)

    cache = commands.add_parser(
        "cache", help="the kernel cache: what it holds (info) or empty it (clear)",
        description="Kernel spectra of the grids already set up, kept on disk so that the "
                    "next run on the same grid starts at once (sacflow.machine.kernel_cache). "
                    "SACFLOW_CACHE_DIR moves it (or 'off'), SACFLOW_CACHE_MAX_BYTES limits it.")
    cache.add_argument("action", choices=("info", "clear"), help="info (default) or clear",
                       nargs="?", default="info")
    cache.set_defaults(handler=_cache)

    schema = commands.add_parser("schema", help="print the JSON schema of a case")
    schema.add_argument(
        "--markdown", action="store_true",
        help="print the reference page of the case format instead (docs/case-format.md)",
    )  # fmt: skip
    schema.set_defaults(handler=_schema)
    return parser


def _add_case_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("configs", nargs="+", type=Path, metavar="CONFIG", help="case file(s)")
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a field, e.g. --set grid.nx=64 --set load_path.0.to=0.19",
    )


def _load_all(args: argparse.Namespace) -> list[Case]:
    """Load every case first; all problems are reported together."""
    cases, problems = [], []
    for path in args.configs:
        try:
            cases.append(load_case(path, args.overrides))
        except ConfigError as exc:
            problems.append(str(exc))
    if problems:
        raise ConfigError("\n".join(problems))
    return cases


def _run(args: argparse.Namespace) -> int:
    from sacflow.machine.malloc import tune_malloc
    from sacflow.runner import run_case  # imports xarray and the solver only when running

    tune_malloc()  # this process is sacflow's own: reuse memory between steps and cases
    status = 0
    for case in _load_all(args):
        try:
            summary = run_case(
                case, args.out, progress=not args.no_progress, resume=not args.restart,
                overwrite=args.overwrite,
            )
        except SacflowError as exc:
            _error(f"{case.name}: {exc}")
            status = EXIT_RUN_FAILED
            continue
        print(summary.line())
    return status


def _campaign(args: argparse.Namespace) -> int:
    from sacflow.campaign import load_campaign, run_campaign  # dask loads only here

    campaign = load_campaign(args.campaign, args.overrides)
    summary = run_campaign(
        campaign, args.out, args.workers, args.scheduler, progress=not args.no_progress,
        overwrite=args.overwrite,
    )
    print(summary.table())
    for record in summary.failed:
        _error(f"{record.name}: {record.error}")
    return EXIT_RUN_FAILED if summary.failed else 0


def _validate(args: argparse.Namespace) -> int:
    from sacflow.config.solver_inputs import check_case_memory

    status = 0
    for case in _load_all(args):
        try:
            memory = check_case_memory(case)  # a grid too large for this machine is refused here
        except SacflowError as exc:
            _error(f"{case.name}: {exc}")
            status = EXIT_RUN_FAILED
            continue
        hertz = case.hertz()
        print(
            f"OK {case.name} ({case.case_id}): a = {hertz.a * 1e6:.3f} µm, "
            f"p0 = {hertz.p0 / 1e9:.3f} GPa, window {case.grid.nx} x {case.grid.ny} cells, "
            f"memory {memory.short()}"
        )
    return status


def _info(args: argparse.Namespace) -> int:
    from sacflow.storage.run_reader import run_info

    empty = []
    for path in args.runs:
        info = run_info(path)
        print(info.report())
        if not (info.complete or info.parts):
            empty.append(str(path))
    if empty:
        _error(f"no run stored at {', '.join(empty)}")
    return EXIT_RUN_FAILED if empty else 0


def _cache(args: argparse.Namespace) -> int:
    from sacflow.machine.kernel_cache import cache_directory, clear_cache, list_entries, max_bytes
    from sacflow.solver.memory_estimate import format_bytes

    root = cache_directory()
    if root is None:
        print("kernel cache: off (SACFLOW_CACHE_DIR)")
        return 0
    if root.exists() and not root.is_dir():
        _error(f"the kernel cache {root} is a file, not a directory: set SACFLOW_CACHE_DIR "
               "to a directory (or to 'off')")
        return EXIT_CONFIG
    if args.action == "clear":
        report = clear_cache(root)
        print(f"kernel cache {root}: removed {report.removed} entries, "
              f"{format_bytes(report.removed_bytes)}")
        for path, reason in report.not_removed:
            _error(f"could not remove {path}: {reason}")
        return EXIT_RUN_FAILED if report.not_removed else 0
    entries = list_entries(root)
    total = sum(entry.nbytes for entry in entries)
    print(f"kernel cache {root}: {len(entries)} entries, {format_bytes(total)} "
          f"(limit {format_bytes(max_bytes())}, least recently used removed first)")
    for entry in reversed(entries):  # most recently used first
        shape = entry.parameters.get("shape")
        grid = " × ".join(str(n) for n in shape) if shape else "?"
        print(f"  {entry.path.name}: {entry.kind}, {grid} cuboids, {format_bytes(entry.nbytes)}, "
              f"last used {time.strftime('%Y-%m-%d %H:%M', time.localtime(entry.last_used))}")
    return 0


def _schema(args: argparse.Namespace) -> int:
    if args.markdown:
        from sacflow.config.schema_doc import case_format_markdown

        print(case_format_markdown(), end="")
        return 0
    print(json.dumps(case_json_schema(), indent=2, ensure_ascii=False))
    return 0


def _error(message: object) -> None:
    print(f"error: {message}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
