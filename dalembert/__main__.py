"""``python -m dalembert``: the ``dalembert`` command."""

import sys

from .cli import main

sys.exit(main())
