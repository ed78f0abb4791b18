"""What the names of a run's cases say, shared by the plotting scripts (no dependency beyond
Python's own library): a triaxial sweep names each shear case ``mur_<mu_r>`` (docs/output.md)."""
import re


def mu_r_of(case):
    """The rolling friction of a case named ``mur_<value>``; NaN for any other name."""
    m = re.fullmatch(r"mur_([0-9.eE+-]+)", case)
    return float(m.group(1)) if m else float("nan")
