"""``python -m zros``: the ``zros`` command, for where the console script is not on ``PATH``."""

from zros.cli.main import main

raise SystemExit(main())
