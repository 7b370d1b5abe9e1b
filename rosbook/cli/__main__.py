import sys

from rosbook.cli import main

sys.exit(main())
