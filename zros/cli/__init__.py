"""The ``zros`` command.

``zros.cli.main`` keeps a table of the commands (name, help line, the function adding the
parser) and imports a command's module only when that command is chosen, so ``zros --help``
loads none of them. Each command module imports the heavy parts of zros (numpy, the type
registry, Zenoh, matplotlib) inside the functions that run its command.
"""
