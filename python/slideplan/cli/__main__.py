"""``python -m slideplan.cli``: the ``slideplan`` command."""

from . import app

app(prog_name="slideplan")
