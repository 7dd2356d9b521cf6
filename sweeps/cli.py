"""The ``nudge`` command: one entry point for everything a user types.

Subcommands::

    nudge plan-push PART --start X,Y,THETA --goal X,Y,THETA [...]   fence pushes (Akella & Mason)
    nudge plan-tumble PART --goal X,Y,THETA,FACE --eps E [...]      tumbles (Marigo & Bicchi)
    nudge certify CONFIG.yaml [...]                                 certify plans (Monte Carlo)
    nudge sweep CONFIG.yaml [...]                                   a parameter study
                                                                    (= python -m sweeps.run)
    nudge parts                                                     the bundled parts and studies

``nudge SUBCOMMAND --help`` explains each one's units, exit statuses and where
results go.  Units everywhere: metres and radians (an angle may carry a
``deg`` suffix).  Exit statuses: 0 success, 1 no plan / not solvable / not
certified, 2 bad input (one ``error:`` line naming the field), 3 internal error,
4 out of memory or a native crash, 130 interrupted.
"""
from __future__ import annotations

import sys
from typing import Optional, Sequence

from sweeps.errors import Exit
from sweeps.terminal import run_main

COMMANDS = {
    "plan-push": ("sweeps.plan_push", "plan normal fence pushes for a polygonal part (Akella & Mason)"),
    "plan-tumble": ("sweeps.plan_tumble", "plan tumbles for a polyhedral part (Marigo & Bicchi)"),
    "certify": ("sweeps.certify", "certify plans against tolerances, friction and robot errors"),
    "sweep": ("sweeps.run", "run a parameter study (Parquet tables, report.html)"),
    "parts": (None, "list the bundled parts, studies and certification configs"),
}


def _help() -> str:
    lines = ["usage: nudge COMMAND [ARGS...]   (nudge --version: the installed versions)", "",
             "nudge: batch planner and robustness analyzer for non-prehensile manipulation.",
             "", "commands:"]
    for name, (_, text) in COMMANDS.items():
        lines.append(f"  {name:12s} {text}")
    lines += ["", "Run 'nudge COMMAND --help' for a command's options. Units: metres and radians "
              "(angles may end in 'deg').",
              "Exit status: 0 success, 1 no plan / not solvable / not certified, 2 bad input, "
              "3 internal error, 4 out of memory or a native crash, 130 interrupted.",
              "Results of certify and sweep go to results/ (Parquet; pandas.read_parquet on a "
              "table's folder)."]
    return "\n".join(lines)


def list_parts() -> int:
    """``nudge parts``: the bundled parts (kind, vertex count), studies and configs."""
    import warnings

    from sweeps import catalog
    from sweeps.partfile import PartFileError, load_part

    out = ["bundled parts (use the name or the path):"]
    for name, path in catalog.bundled_parts().items():
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                p = load_part(path)
            desc = f"{p.kind}, {len(p.vertices)} vertices"
            if p.cad is not None:
                desc += f" (hull of {p.source.name}, {p.units})"
            if p.description:
                desc += f": {p.description}"
        except PartFileError as exc:
            desc = f"unreadable ({exc})"
        out.append(f"  {name:22s} {desc}")
    out.append("bundled studies (nudge sweep NAME.yaml):")
    for name, path in catalog.bundled_studies().items():
        first = next((ln[1:].strip() for ln in path.read_text().splitlines() if ln.startswith("#")), "")
        out.append(f"  {name + '.yaml':22s} {first}")
    out.append("certification configs (nudge certify PATH):")
    for name, path in catalog.bundled_certify_configs().items():
        out.append(f"  {str(path.relative_to(catalog.EXAMPLES.parent)):34s}")
    sys.stdout.write("\n".join(out) + "\n")
    return 0


def version_line() -> str:
    """``nudge X.Y.Z (python ..., jax ..., mujoco ..., numpy ...)``: the installed
    distributions' versions, read from their metadata (nothing heavy is imported)."""
    import platform
    from importlib import metadata

    def ver(dist):
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return "not installed"

    deps = ", ".join(f"{d} {ver(d)}" for d in ("jax", "jaxlib", "mujoco", "numpy"))
    return f"nudge {ver('nudge')} (python {platform.python_version()}, {deps})"


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run ``nudge``; returns the exit status."""
    import importlib

    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        sys.stdout.write(_help() + "\n")
        return 0 if argv else Exit.INPUT
    if argv[0] in ("-V", "--version"):
        sys.stdout.write(version_line() + "\n")
        return 0
    cmd, rest = argv[0], argv[1:]
    if cmd not in COMMANDS:
        sys.stderr.write(f"error: unknown command {cmd!r}; commands: {', '.join(COMMANDS)} "
                         "(see nudge --help)\n")
        return Exit.INPUT
    module, _ = COMMANDS[cmd]
    if module is None:
        if rest and rest[0] in ("-h", "--help"):
            sys.stdout.write("usage: nudge parts\n\nList the bundled parts, studies and "
                             "certification configs (exit status 0).\n")
            return 0
        return list_parts()
    return importlib.import_module(module).main(rest, prog=f"nudge {cmd}")


def entry() -> None:
    """The console script (``[project.scripts] nudge``)."""
    run_main(main, supervised=True)


if __name__ == "__main__":
    entry()
