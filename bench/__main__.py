import sys

from diffbench.bench.cli import main

sys.exit(main())
