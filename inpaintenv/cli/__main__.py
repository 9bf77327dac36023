"""``python -m inpaintenv.cli``: the ``inpaintenv`` program."""

import sys

from .main import main

sys.exit(main())
