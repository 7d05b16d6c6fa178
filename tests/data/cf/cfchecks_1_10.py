"""Run ``cfchecker`` (4.1.0, the newest on PyPI) on CF-1.10 files, offline.

cfchecker 4.1.0 knows the CF versions up to 1.8 and refuses any other ``Conventions`` value ("does not
appear to contain CF Convention data"). This runner adds 1.9 and 1.10 to the versions it accepts, so that
it applies every check it has (those of CF-1.8, which CF-1.10 keeps) to the package's CF-1.10 files; and
it reads the standard-name, area-type and region tables from the small offline files beside this one
instead of downloading them. Usage: ``python cfchecks_1_10.py FILE...`` (exit status: the number of errors).
"""

import sys
from pathlib import Path

from cfchecker import cfchecks

HERE = Path(__file__).parent
cfchecks.cfVersions += [cfchecks.CFVersion((1, 9)), cfchecks.CFVersion((1, 10))]

if __name__ == "__main__":
    sys.argv = ["cfchecks", "-v", "1.10", "-s", str(HERE / "standard-names.xml"), "-a", str(HERE / "area-types.xml"),
                "-r", str(HERE / "region-names.xml"), *sys.argv[1:]]
    cfchecks.main()
