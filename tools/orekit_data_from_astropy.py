"""Write a minimal Orekit data directory from what astropy ships (no network, no orekit-data).

Orekit (an independent flight-dynamics library, used only to make test data in a scratch
environment, never a dependency) needs leap seconds, Earth-orientation parameters and, for a
gravity field, a coefficient file. The ``orekit-data`` bundle cannot be downloaded on the
project's machines, and its tables would differ from the ones the package computes with anyway,
so this script writes Orekit's data from the package's own sources:

* ``tai-utc.dat``: the leap seconds of the IERS table bundled with ``astropy-iers-data``
  (``Leap_Second.dat``), in the USNO format Orekit reads by default (it does not read the IERS
  file under its own name without an explicit loader);
* ``finals2000A.all``: the IERS-A Earth-orientation table bundled with ``astropy-iers-data``,
  the one :func:`orbit.timescales.iers_table` uses, with the celestial-pole offsets dX, dY
  written as zeros (both bulletins): astropy's GCRS → CIRS is ERFA ``c2i06a`` (the IAU
  2006/2000A model without the observed offsets), while Orekit adds them (0.29 mas = 1.4e-9 rad
  on 2026-03-20, 1 cm at 7000 km). Like astropy's ``IERS_A``, Orekit takes the Bulletin B
  values of UT1 − UTC and polar motion where the file has them, else the Bulletin A ones
  (checked: the daily values of both are identical from 2020 to the table's last prediction).
  The file's last rows (dates without values) are dropped, as Orekit would read them as zeros;
  but past its table Orekit takes the EOP as zero anyway, where astropy keeps the last values,
  so the two differ after the table's last prediction (2027-10-29 in astropy-iers-data
  0.2026.11.2.0.34.55). ``--keep-cip-offsets`` keeps dX, dY (to measure their
  effect);
* ``egm2008.gfc``: the package's EGM2008 coefficients (``orbit/data/egm2008.npz``: fully
  normalised, tide-free, GM = 3.986004415e14 m³/s², a = 6 378 136.3 m) to degree and order
  ``--degree`` (default 70), in the ICGEM format Orekit's ``ICGEMFormatReader`` reads; no
  time-variable terms.

Run it with any Python that has numpy and astropy (the package need not be installed)::

    python tools/orekit_data_from_astropy.py /work/scratch/orekit-data

``tools/orekit_numerical_orbit_reference.py`` uses the directory.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
EGM2008 = REPO / "orbit" / "data" / "egm2008.npz"

# Columns of finals2000A.all (0-based slices of ReadMe.finals2000A's 1-based ranges).
UT1_A = slice(58, 68)
DX_A, DY_A = slice(97, 106), slice(116, 125)
DX_B, DY_B = slice(165, 175), slice(175, 185)


def _put(line: list[str], cols: slice, text: str) -> None:
    width = cols.stop - cols.start
    assert len(text) <= width, (text, width)
    line[cols] = list(text.rjust(width))


def tai_utc_dat(src: Path) -> str:
    """The IERS ``Leap_Second.dat`` (MJD, day, month, year, TAI − UTC) in the USNO format."""
    months = "JAN FEB MAR APR MAY JUN JUL AUG SEP OCT NOV DEC".split()
    lines = []
    for raw in src.read_text().splitlines():
        if raw.lstrip().startswith("#") or not raw.strip():
            continue
        mjd, _day, month, year, tai_utc = raw.split()
        lines.append(
            f" {int(year)} {months[int(month) - 1]:>3}  1 =JD {float(mjd) + 2400000.5:.1f}  "
            f"TAI-UTC= {float(tai_utc):10.7f} S + (MJD - 41317.) X 0.0      S"
        )
    return "\n".join(lines) + "\n"


def finals_for_orekit(src: Path, keep_cip_offsets: bool = False) -> str:
    """The finals2000A.all text without the rows that have no UT1 − UTC and, unless
    ``keep_cip_offsets``, with dX = dY = 0 wherever the file has a value."""
    out = []
    for raw in src.read_text().splitlines():
        if not raw[UT1_A].strip():
            continue
        line = list(raw.ljust(185))
        for cols, fmt in ((DX_A, "9.3f"), (DY_A, "9.3f"), (DX_B, "10.3f"), (DY_B, "10.3f")):
            if raw[cols].strip() and not keep_cip_offsets:
                _put(line, cols, f"{0.0:{fmt}}")
        out.append("".join(line))
    return "\n".join(out) + "\n"


def write_gfc(path: Path, degree: int) -> None:
    """EGM2008 to ``degree`` × ``degree`` as an ICGEM file (fully normalised, tide-free)."""
    with np.load(EGM2008) as d:
        C, S = d["C"], d["S"]
        mu, radius = float(d["mu"]), float(d["radius"])
    lines = [
        f"EGM2008 to degree and order {degree} from orbit/data/egm2008.npz",
        "(written by tools/orekit_data_from_astropy.py for Orekit test data)",
        "begin_of_head ============================================",
        "product_type           gravity_field",
        "modelname              EGM2008",
        f"earth_gravity_constant {mu!r}",
        f"radius                 {radius!r}",
        f"max_degree             {degree}",
        "errors                 no",
        "norm                   fully_normalized",
        "tide_system            tide_free",
        "",
        "key    L    M         C                          S",
        "end_of_head ==============================================",
    ]
    for n in range(degree + 1):
        for m in range(n + 1):
            lines.append(f"gfc {n:4d} {m:4d} {C[n, m]: .18e} {S[n, m]: .18e}")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("directory", type=Path)
    p.add_argument("--degree", type=int, default=70)
    p.add_argument("--keep-cip-offsets", action="store_true",
                   help="keep the celestial-pole offsets dX, dY of finals2000A.all")  # fmt: skip
    args = p.parse_args()
    import astropy_iers_data

    d = args.directory
    d.mkdir(parents=True, exist_ok=True)
    (d / "tai-utc.dat").write_text(tai_utc_dat(Path(astropy_iers_data.IERS_LEAP_SECOND_FILE)))
    src = Path(astropy_iers_data.IERS_A_FILE)
    (d / "finals2000A.all").write_text(finals_for_orekit(src, args.keep_cip_offsets))
    write_gfc(d / "egm2008.gfc", args.degree)
    print(f"wrote {d}: tai-utc.dat, finals2000A.all, egm2008.gfc (degree {args.degree})")


if __name__ == "__main__":
    main()
