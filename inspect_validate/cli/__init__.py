"""The ``inspect-validate`` command line: one module per command, each parsing its options
and calling the library.

Only click and the error types are imported at start-up, and of the commands only the
one that runs (click's lazily loaded subcommands); numpy, numba, OpenCV and the rest
load inside the command that needs them, so ``--help`` is instant.
Exit codes: see :mod:`inspect_validate.errors` and the manual, "Exit codes".
"""

from __future__ import annotations

import importlib
import sys
import traceback
from typing import NoReturn

import click

from inspect_validate import __version__
from inspect_validate.errors import (
    EXIT_INPUT,
    EXIT_INTERNAL,
    InspectValidateError,
)

#: Each command and the function of ``inspect_validate.cli.<module>`` that is it.
COMMANDS = {
    "analyze-spectra": "analyze_spectra",
    "capture": "capture",
    "characterize": "characterize",
    "design": "design",
    "devices": "devices",
    "history": "history",
    "init": "init",
    "measure": "measure",
    "predict": "predict",
    "rois": "rois",
    "train": "train",
    "verify": "verify",
    "watch": "watch",
}


class _Commands(click.Group):
    """The commands, each imported when it is asked for (click's documented pattern for
    lazily loaded subcommands): a run imports its own command's module, not thirteen."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return None
        name = COMMANDS[cmd_name]
        command = getattr(importlib.import_module(f"inspect_validate.cli.{name}"), name)
        assert isinstance(command, click.Command) and command.name == cmd_name
        return command


@click.group(cls=_Commands, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="inspect-validate")
def cli() -> None:
    """Design and verify machine-vision inspection stations from spectra and images."""


# The commands that capture frames (kept on an interruption, resumable), and what lets
# a command that ran out of memory do with less.
_CAPTURING = {"capture", "verify", "train", "watch", "characterize", "design"}
_RESUMABLE = {"capture", "characterize"}
_LESS_MEMORY = {
    "measure": "measure fewer or smaller frames at a time",
    "rois": "give fewer or smaller frames",
    "predict": "predict fewer combinations at a time, or on a coarser wavelength grid",
    "analyze-spectra": "give fewer or shorter spectra",
    "design": "give fewer candidate lights, or leave out --choose",
}


def _command_name(argv) -> str | None:
    """The command a command line runs (its first word that is not an option)."""
    return next(
        (str(a) for a in (sys.argv[1:] if argv is None else argv) if not str(a).startswith("-")),
        None,
    )


def _interrupted(argv) -> NoReturn:
    """End a run a signal or Ctrl-C stopped: exit 130, saying what was kept."""
    command = _command_name(argv)
    kept = ""
    if command in _CAPTURING:
        kept = "; any frames saved so far are kept"
        args = [str(a) for a in (sys.argv[1:] if argv is None else argv)]
        # The others have no --resume; a production capture's resume takes its one step
        # again (its frames are of parts gone by), so it is not advised either.
        if command in _RESUMABLE and "--production" not in args:
            kept += f" ({command} --resume continues)"
    click.echo(f"interrupted{kept}", err=True)
    sys.exit(130)


def main(argv=None) -> None:
    """Console entry point: run the CLI and map errors to documented exit codes."""
    from inspect_validate import interruption

    # SIGTERM (a service manager, kill) ends the tool as Ctrl-C does: saved frames kept,
    # exit 130 with a message, not the bare 143 of the default action.
    interruption.reset()
    interruption.install()
    try:
        from inspect_validate.files import cleaned_outputs

        with cleaned_outputs():  # a refused or failed run leaves no empty folders
            cli.main(args=argv, prog_name="inspect-validate", standalone_mode=False)
    except (click.exceptions.Abort, KeyboardInterrupt):
        _interrupted(argv)
    except click.ClickException as exc:
        exc.show()
        sys.exit(EXIT_INPUT)
    except InspectValidateError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(exc.exit_code)
    except MemoryError:
        command = _command_name(argv)
        less = _LESS_MEMORY.get(command or "", "give it smaller inputs")
        click.echo(f"error: out of memory in {command or 'inspect-validate'}; {less}", err=True)
        sys.exit(EXIT_INTERNAL)
    except Exception:
        if interruption.requested() is not None:
            # A library turned the stop's exception into one of its own (pydantic-core
            # wraps one raised while it builds a validator, at an import, in SchemaError):
            # the run was still stopped, not broken.
            _interrupted(argv)
        traceback.print_exc()
        click.echo(
            "internal error in inspect-validate: please report it with the traceback above",
            err=True,
        )
        sys.exit(EXIT_INTERNAL)
    sys.exit(0)
