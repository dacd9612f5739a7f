"""One module per ``zros`` command, named by the command: ``zros topic`` is ``topic.py``.

Each has ``add_parser(commands, help_line)``, and each of its parsers has as ``run`` default
the function that runs it; ``zros.cli.main`` imports only the chosen module.
"""
