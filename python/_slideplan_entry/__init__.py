"""The ``slideplan`` command's entry point, kept outside the package: importing ``slideplan`` takes
about 0.3 s (NumPy, the C++ core, typer), and a Ctrl-C in that time must end the command as one during
a run does (exit 130, one line), not with a traceback. Nothing else belongs here."""

import sys

EXIT_INTERRUPTED = 130  # slideplan.cli.common's, copied: a Ctrl-C may stop that import (test_interrupt checks)


def main() -> None:
    try:
        from slideplan.cli import app
    except KeyboardInterrupt:
        _aborted()
    except ImportError as error:
        # A Ctrl-C inside a C extension's import (NumPy's) comes out as that package's ImportError ("Importing
        # the numpy C-extensions failed"), which would send the user to reinstall it: an interrupt all the same.
        if _interrupted(error):
            _aborted()
        raise
    app()


def _interrupted(error: BaseException) -> bool:
    """Whether a KeyboardInterrupt lies anywhere in the chain of causes that led to ``error``."""
    seen = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt):
            return True
        seen.add(id(error))
        error = error.__cause__ or error.__context__
    return False


def _aborted() -> None:
    sys.stderr.write("slideplan: aborted\n")
    sys.exit(EXIT_INTERRUPTED)
