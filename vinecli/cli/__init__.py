"""The command line (Typer): each command parses, calls one library function and renders the result.

One module per command group, named after it (:mod:`~vinecli.cli.terrain` is ``vinecli terrain``, ... : those
names repeat the packages' on purpose), :mod:`~vinecli.cli.app` (the app and ``main``),
:mod:`~vinecli.cli.options` (flags several commands share) and :mod:`~vinecli.cli.console` (the consoles).
The top floor: may import anything; ``vinecli --help`` imports no numpy or pydantic (defaults come from light
modules).
"""
