"""The ``zros`` command.

``zros.cli.main`` keeps a table of the commands (name and help line); a command's module is
``zros.cli.verbs.<command>``, imported only when that command is chosen, so ``zros --help``
loads none of them. Each command module imports the heavy parts of zros (numpy, the type
registry, Zenoh, matplotlib) inside the functions that run its command. Helpers several
commands share (``shared``, ``message_text``, ...) sit beside ``main``.
"""
