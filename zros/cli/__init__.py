"""The ``zros`` command."""
