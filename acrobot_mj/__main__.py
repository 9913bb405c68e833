"""``python -m acrobot_mj``: the ``acrobot-mj`` command."""

import sys

from acrobot_mj.cli import main

sys.exit(main())
