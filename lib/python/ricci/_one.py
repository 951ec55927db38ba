"""One mesh of `ricci batch`, in a process of its own: python -m ricci._one PATH FOLDER OPTIONS_JSON.

Writes FOLDER as `ricci uniformize -o FOLDER` does, or a report.json with the failure's status and
message (the partial report when the pipeline started). Exit code 0 on success, 3 on a failure
recorded in FOLDER."""

import json
import os
import sys
import time

import ricci
from ricci.batch import write_failure


def main(argv):
    path, folder, options = argv[1], argv[2], json.loads(argv[3])
    # A test aid: the process aborts (as a crash of the library would end it) for matching paths.
    crash = os.environ.get("RICCI_BATCH_TEST_ABORT")
    if crash and crash in path:
        os.abort()
    # A test aid: the process never finishes (as a run past --timeout would not) for matching paths.
    hang = os.environ.get("RICCI_BATCH_TEST_HANG")
    if hang and hang in path:
        time.sleep(3600)
    pictures = options.pop("pictures", True)
    try:
        result = ricci.uniformize(path, **options)
        ricci.write_outputs(result, folder, pictures=pictures)
        return 0
    except ricci.RicciError as e:
        report = e.result.report if e.result is not None else {}
        report.update({"status": e.status, "message": e.message, "failed_stage": e.stage, "input": path})
        write_failure(folder, report)
        return 3


if __name__ == "__main__":
    sys.exit(main(sys.argv))
