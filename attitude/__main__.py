"""``python -m attitude`` is the same as the ``attitude`` command."""

from attitude.cli import main

raise SystemExit(main())
