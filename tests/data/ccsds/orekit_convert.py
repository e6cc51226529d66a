"""Have Orekit read the KVN sources and write them again (step 2 of 2 of the CCSDS test data).

Orekit (through ``orekit_jpype``, which bundles Orekit's jars; Java 17) is an independent
implementation of CCSDS 502.0-B-3 (OEM) and 504.0-B-2 (AEM), used here only to write test
files: it is never a dependency of the package. Run it in a scratch environment::

    python3 -m venv /work/scratch/orekitvenv
    /work/scratch/orekitvenv/bin/pip install orekit_jpype astropy
    /work/scratch/orekitvenv/bin/python tests/data/ccsds/orekit_convert.py

It writes, beside this file, from ``attitude_q.aem``, ``attitude_angvel.aem`` and ``orbit.oem``
(``make_sources.py``):

* ``orekit_attitude_q.xml.aem``, ``orekit_attitude_angvel.xml.aem``, ``orekit_orbit.xml.oem``:
  the same messages as XML (NDM/XML, CCSDS 505.0-B-3 schema), as Orekit writes them;
* ``orekit_orbit_stream.xml.oem``: the OEM as Orekit's ``EphemerisOemWriter`` writes it, in
  XML without the ``<segment>`` element (a form ccsds-ndm-py refuses);
* ``orekit_attitude_q_tai.aem``, ``orekit_attitude_q_gps.aem``: the attitude of
  ``attitude_q.aem`` written by Orekit in KVN with ``TIME_SYSTEM = TAI`` and ``GPS``: the same
  instants under two labels (GPS = TAI - 19 s), for the time-system test;
* from ``estimate.acm`` (an ACM of the MEKF's estimate, CCSDS 504.0-B-2 sect. 5):
  ``orekit_estimate.acm``, the message as Orekit's ``AcmWriter`` writes it again (KVN), and
  ``orekit_estimate_acm.txt``, the values Orekit's ``AcmParser`` read, in SI units (the
  elements of every attitude and covariance line; tests/test_acm.py compares them with ours).

``python orekit_convert.py --acm FILE.acm`` prints that table for any ACM (tests/test_acm.py
runs it when ``ATTITUDE_OREKIT_PYTHON`` names this environment's interpreter, or when
``orekit_jpype`` can be imported).

Orekit needs the UTC-TAI history to read UTC epochs: it is written from astropy's leap-second
table to a temporary directory (``tai-utc.dat``, the USNO format Orekit reads); no other Orekit
data are needed (GCRF and EME2000 are defined without Earth orientation data).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _leap_seconds(directory: Path) -> None:
    from astropy.time import Time
    from astropy.utils.iers import LeapSeconds

    table = LeapSeconds.auto_open()
    months = "JAN FEB MAR APR MAY JUN JUL AUG SEP OCT NOV DEC".split()
    lines = []
    for row in table:
        if int(row["year"]) < 1972:
            continue
        t = Time(f"{int(row['year'])}-{int(row['month']):02d}-01", scale="utc")
        lines.append(
            f" {int(row['year'])} {months[int(row['month']) - 1]:>3}  1 =JD {t.jd:.1f}  "
            f"TAI-UTC= {float(row['tai_utc']):5.1f}       S + (MJD - 41317.) X 0.0      S"
        )
    (directory / "tai-utc.dat").write_text("\n".join(lines) + "\n")


def main() -> None:
    import sys

    import orekit_jpype as orekit

    orekit.initVM()
    with tempfile.TemporaryDirectory() as tmp:  # Orekit reads it lazily: kept until the end
        _leap_seconds(Path(tmp))
        from java.io import File
        from org.orekit.data import DataContext, DirectoryCrawler

        manager = DataContext.getDefault().getDataProvidersManager()
        manager.addProvider(DirectoryCrawler(File(tmp)))
        _earth_without_ephemerides()
        if sys.argv[1:2] == ["--acm"]:
            print(acm_values(Path(sys.argv[2])), end="")
        else:
            _convert()


def _earth_without_ephemerides() -> None:
    """CENTER_NAME = EARTH makes Orekit's parsers load the Earth from JPL ephemerides, which
    are not here and not needed to convert a message: a stand-in Earth (GCRF, Earth's GM; its
    position is never asked for) is registered instead."""
    from jpype import JImplements, JOverride
    from org.orekit.bodies import CelestialBodyFactory
    from org.orekit.frames import FramesFactory
    from org.orekit.utils import Constants

    @JImplements("org.orekit.bodies.CelestialBody")
    class Earth:
        @JOverride
        def getInertiallyOrientedFrame(self):
            return FramesFactory.getGCRF()

        @JOverride
        def getBodyOrientedFrame(self):
            return FramesFactory.getGCRF()

        @JOverride
        def getGM(self):
            return Constants.EIGEN5C_EARTH_MU

        @JOverride
        def getName(self):
            return "Earth"

        @JOverride
        def getPosition(self, date, frame):
            raise NotImplementedError("the stand-in Earth has no ephemeris")

    @JImplements("org.orekit.bodies.CelestialBodyLoader")
    class Loader:
        @JOverride
        def loadCelestialBody(self, name):
            return Earth()

    CelestialBodyFactory.addCelestialBodyLoader(CelestialBodyFactory.EARTH, Loader())


def _parse(kind: str, path: Path):
    from org.orekit.data import DataSource
    from org.orekit.files.ccsds.ndm import ParserBuilder

    parser = getattr(ParserBuilder(), f"build{kind}Parser")()
    return parser.parseMessage(DataSource(str(path)))


def _write(kind: str, message, path: Path, xml: bool) -> None:
    from java.lang import StringBuilder
    from org.orekit.files.ccsds.ndm import WriterBuilder
    from org.orekit.files.ccsds.utils.generation import KvnGenerator, XmlGenerator
    from org.orekit.utils import Constants

    writer = getattr(WriterBuilder(), f"build{kind}Writer")()
    out = StringBuilder()
    if xml:
        gen = XmlGenerator(out, XmlGenerator.DEFAULT_INDENT, path.name, Constants.JULIAN_DAY,
                           False, XmlGenerator.NDM_XML_V3_SCHEMA_LOCATION)  # fmt: skip
    else:
        gen = KvnGenerator(out, 25, path.name, Constants.JULIAN_DAY, 60)
    writer.writeMessage(gen, message)
    gen.close()
    path.write_text(str(out.toString()))
    print("written", path.name)


def _convert() -> None:
    from org.orekit.files.ccsds.definitions import TimeSystem

    for name in ("attitude_q", "attitude_angvel"):
        msg = _parse("Aem", HERE / f"{name}.aem")
        _write("Aem", msg, HERE / f"orekit_{name}.xml.aem", xml=True)
    for system in ("TAI", "GPS"):
        msg = _parse("Aem", HERE / "attitude_q.aem")
        for seg in msg.getSegments():
            seg.getMetadata().setTimeSystem(getattr(TimeSystem, system))
        _write("Aem", msg, HERE / f"orekit_attitude_q_{system.lower()}.aem", xml=False)
    acm = _parse("Acm", HERE / "estimate.acm")
    _write("Acm", acm, HERE / "orekit_estimate.acm", xml=False)
    (HERE / "orekit_estimate_acm.txt").write_text(acm_values(HERE / "estimate.acm"))
    print("written orekit_estimate_acm.txt")
    msg = _parse("Oem", HERE / "orbit.oem")
    _write("Oem", msg, HERE / "orekit_orbit.xml.oem", xml=True)
    _write_streaming_oem(msg, HERE / "orekit_orbit_stream.xml.oem")


def acm_values(path: Path) -> str:
    """What Orekit's AcmParser reads from an ACM, as text: a line per attitude state
    (``ATT <ATT_ID> <s since EPOCH_TZERO> <elements in SI>``: quaternion Q1 Q2 Q3 QC, then the
    rates in rad/s) and per covariance line (``COV <COV_ID> <s> <diagonal in SI>``: rad², then
    (rad/s)²), numbers as Java prints doubles (they read back exactly)."""
    msg = _parse("Acm", path)
    seg = msg.getSegments().get(0)
    t0 = seg.getMetadata().getEpochT0()
    data = seg.getData()
    out = [
        f"# Orekit AcmParser values of {path.name}: OBJECT_NAME {seg.getMetadata().getObjectName()}"
        f", EPOCH_TZERO {t0}, TIME_SYSTEM {seg.getMetadata().getTimeSystem()}"
    ]
    for block in data.getAttitudeBlocks():
        m = block.getMetadata()
        a, b = m.getEndpoints().getFrameA().getName(), m.getEndpoints().getFrameB().getName()
        rate = m.getRateType()  # None: no RATE_TYPE line
        out.append(f"# ATT {m.getAttID()} {a} -> {b} {m.getAttitudeType().name()} "
                   f"{rate.name() if rate is not None else 'NONE'}")  # fmt: skip
        for st in block.getAttitudeStates():
            vals = " ".join(str(x) for x in st.getElements())
            out.append(f"ATT {m.getAttID()} {st.getDate().durationFrom(t0)} {vals}")
    for block in data.getCovarianceBlocks():
        m = block.getMetadata()
        out.append(f"# COV {m.getCovID()} {m.getCovType().name()} "
                   f"{m.getCovReferenceFrame().getName()}")  # fmt: skip
        for c in block.getCovariances():
            mat = c.getMatrix()
            vals = " ".join(str(mat.getEntry(i, i)) for i in range(mat.getRowDimension()))
            out.append(f"COV {m.getCovID()} {c.getDate().durationFrom(t0)} {vals}")
    ad = data.getAttitudeDeterminationBlock()
    if ad is not None:
        out.append(f"# AD {ad.getMethod().name()} {ad.getAttitudeStates().name()} "
                   f"{ad.getCovarianceType().name()} {ad.getRateStates().name()}")  # fmt: skip
    return "\n".join(out) + "\n"


def _write_streaming_oem(oem, path: Path) -> None:
    """The OEM as Orekit's ``EphemerisOemWriter`` writes an ephemeris (what a user of
    Orekit's propagators writes): in XML it leaves out the ``<segment>`` element."""
    from java.lang import StringBuilder
    from org.orekit.files.ccsds.ndm import WriterBuilder
    from org.orekit.files.ccsds.ndm.odm.oem import EphemerisOemWriter
    from org.orekit.files.ccsds.utils import FileFormat
    from org.orekit.utils import Constants

    seg = oem.getSegments().get(0)
    writer = EphemerisOemWriter(WriterBuilder().buildOemWriter(), oem.getHeader(),
                                seg.getMetadata(), FileFormat.XML, path.name,
                                Constants.JULIAN_DAY, 0)  # fmt: skip
    out = StringBuilder()
    writer.write(out, oem)
    path.write_text(str(out.toString()))
    print("written", path.name)


if __name__ == "__main__":
    main()
