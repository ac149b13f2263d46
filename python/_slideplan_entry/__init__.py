"""The ``slideplan`` command's entry point, kept outside the package: importing ``slideplan`` takes
about 0.3 s (NumPy, the C++ core, typer), and a Ctrl-C in that time must end the command as one during
a run does (exit 130, one line), not with a traceback. Nothing else belongs here."""

import sys

EXIT_INTERRUPTED = 130  # slideplan.cli.common's, copied: a Ctrl-C may stop that import (test_interrupt checks)


def main() -> None:
    try:
        from slideplan.cli import app
    except KeyboardInterrupt:
        sys.stderr.write("slideplan: aborted\n")
        sys.exit(EXIT_INTERRUPTED)
    app()
