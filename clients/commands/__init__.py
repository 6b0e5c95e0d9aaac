"""The ``plotgate`` command's subcommands, one module each: its arguments
(``add_command(sub)``) and its run function (``run(args)``, the exit status).
:mod:`plotgate.clients.cli` assembles them."""
