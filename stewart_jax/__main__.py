"""``python -m stewart_jax …`` is the ``stewart-jax`` command line."""

import sys

from ._cli import main

sys.exit(main())
