"""python -m ricci batch ... | python -m ricci summarize OUTDIR (see ricci.batch)."""

import sys

from ricci.batch import main

sys.exit(main())
