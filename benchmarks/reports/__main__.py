"""``python -m benchmarks.reports DIR``: rewrite the reports of ``DIR`` from its ``cells.jsonl``
and print ``table.md``."""

import sys

from benchmarks.reports import write_report

if __name__ == "__main__":
    print(write_report(sys.argv[1]))
