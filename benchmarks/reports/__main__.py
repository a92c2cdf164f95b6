"""``python -m benchmarks.reports DIR``: rewrite the reports of ``DIR`` from its ``cells.jsonl``
and print ``table.md``. The plug-ins the cells were measured with are loaded again from the specs
their records keep (:func:`benchmarks.sweep.plugins.load_recorded`), as ``bnerr bench
--report-only`` does."""

import sys

from benchmarks.reports import write_report
from benchmarks.sweep.plugins import load_recorded
from benchmarks.sweep.records import load_records

if __name__ == "__main__":
    records = load_records(sys.argv[1])
    for note in load_recorded(records):
        print(f"benchmarks.reports: {note}", file=sys.stderr)
    print(write_report(sys.argv[1], records))
