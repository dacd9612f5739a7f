"""The ``zros`` command.

Each command module imports the heavy parts of zros (numpy, the type registry, Zenoh,
matplotlib) inside the functions that run its command, so ``zros --help`` loads none of them.
"""
