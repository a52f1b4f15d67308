"""`python -m rw_fdi_ros.cli`: the same as `rw-fdi`."""
import sys

from . import main

sys.exit(main())
