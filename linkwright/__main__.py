"""``python -m linkwright``: the same as the ``linkwright`` command."""
import sys

from .cli import main

sys.exit(main())
