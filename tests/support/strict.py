"""Whether a missing tool or input fails a test instead of skipping it (exit
77): under CI (CI=true) and under scripts/test.sh (TALLY_TEST_STRICT=1),
which install everything the suite needs. tests/support/strict.hpp is the
same rule for the C++ tests."""
import os
import sys

SKIP = 77  # ctest's SKIP_RETURN_CODE for the tests that skip


def strict():
    return os.environ.get("CI") == "true" or os.environ.get("TALLY_TEST_STRICT") == "1"


def skip_or_fail(message):
    """Exits 77 (skipped) with `message`, or 1 where tests are strict."""
    if strict():
        print("FAIL: %s (required where CI=true or TALLY_TEST_STRICT=1)" % message, file=sys.stderr)
        sys.exit(1)
    print("skipped: " + message, file=sys.stderr)
    sys.exit(SKIP)
