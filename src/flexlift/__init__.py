"""flexlift: raise a sunken flexible hull with controlled lift bags.

The analysis flows one way, one stage per module:

    scenario -> hull -> beam -> modes -> liftplan/loads -> statespace -> reduce
             -> fuzzy/control + bags/seabed/hydro -> simulate -> results -> plots/report

Units are SI throughout (m, s, kg, N, Pa, rad); tonnes, degrees and bar appear only in
scenario files and reports.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("flexlift")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

__all__ = ["__version__"]
