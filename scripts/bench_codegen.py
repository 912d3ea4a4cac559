"""Speed of the generated Puma 560 code against Pinocchio and the Robotics Toolbox (issue 4).

Run: .venv/bin/python scripts/bench_codegen.py [--markdown docs/bench.md.part] [--help]
The same as `symdyn bench` (`make bench` installs its peers first); see symdyn/bench/compare.py.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from symdyn.bench.compare import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
