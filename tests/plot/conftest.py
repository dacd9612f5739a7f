"""Plots render with Agg (no display); the ``cli`` fixture runs the real ``zros`` command."""

from __future__ import annotations

import matplotlib

from tests.cli.conftest import Cli, cli

matplotlib.use('Agg')

__all__ = ['Cli', 'cli']
