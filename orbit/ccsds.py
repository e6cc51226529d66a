"""CCSDS Navigation Data Messages in XML (NDM/XML, CCSDS 505.0-B): the common structure.

One reader for the XML form of the messages the packages read (OEM here, AEM in
:mod:`attitude.aem`): it returns what a KVN reader sees, a header of ``KEYWORD: value``
strings and segments of (metadata dict, data elements), so the interpretation of a message
(frames, time systems, quaternion order...) is written once for both forms.

Structure read::

    <oem|aem id="CCSDS_OEM_VERS" version="2.0">      (root: message kind and version)
      <header> KEYWORD elements </header>
      <body>
        <segment> <metadata>...</metadata> <data>...</data> </segment>   (one or more)
      </body>

Namespaces are ignored (the qualified and unqualified schemas read alike) and ``COMMENT``
elements skipped. A body holding ``<metadata>``/``<data>`` pairs without the ``<segment>``
wrapper is read too: Orekit's streaming OEM writer (``EphemerisOemWriter``, 13.x) writes
that form, which the schema does not allow and ccsds-ndm-py refuses ("missing field
`segment`").

The parser is the standard library's (``xml.etree.ElementTree`` on expat, which refuses
entity-expansion bombs since expat 2.4.1); files are read whole.
"""

from __future__ import annotations

from typing import Any
from xml.etree import ElementTree

__all__ = ["XmlMessage", "is_xml", "leaves", "read_xml"]


def _tag(el: Any) -> str:
    """The element's name without its namespace."""
    t = el.tag
    return t.rsplit("}", 1)[-1] if isinstance(t, str) else ""


def is_xml(data: bytes) -> bool:
    """Whether a message file's bytes are XML (the first non-blank character is ``<``)."""
    return data.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"<")


def _keywords(el: Any) -> dict[str, str]:
    """``KEYWORD -> text`` of the simple child elements (COMMENT and containers skipped)."""
    out = {}
    for child in el:
        name = _tag(child)
        if name == "COMMENT" or len(child):
            continue
        out[name] = (child.text or "").strip()
    return out


def leaves(el: Any) -> list[tuple[str, str, dict[str, str]]]:
    """The leaf elements below ``el`` in document order: (name, text, attributes), COMMENT
    skipped (a data entry such as ``<stateVector>`` or ``<attitudeState>``)."""
    out = []
    for child in el.iter():
        if child is el or len(child):
            continue
        name = _tag(child)
        if name and name != "COMMENT":
            out.append((name, (child.text or "").strip(), dict(child.attrib)))
    return out


class XmlMessage:
    """A parsed NDM/XML message.

    Attributes
    ----------
    kind : str
        The root element's name in upper case (``OEM``, ``AEM``...).
    version : str
        The root's ``version`` attribute (``"2.0"``).
    header : dict of str
        The header keywords.
    segments : list of (dict of str, list of Element)
        Per segment, the metadata keywords and the data entries (the children of ``<data>``
        other than COMMENT), to be read with :func:`leaves`.
    """

    def __init__(self, kind: str, version: str, header: dict[str, str], segments: list) -> None:
        self.kind, self.version, self.header, self.segments = kind, version, header, segments


def read_xml(data: bytes, where: str) -> XmlMessage:
    """Parse the XML of a message.

    Parameters
    ----------
    data : bytes
        The file's bytes (decoded by the parser as the XML declaration says).
    where : str
        The file name, for messages.

    Raises
    ------
    ValueError
        Not well-formed XML, or not a message with a header and a body (the message names
        ``where`` and what is missing); the callers raise their package's error from it.
    """
    try:
        root = ElementTree.fromstring(data)
    except ElementTree.ParseError as exc:
        raise ValueError(f"{where}: not well-formed XML ({exc})") from None
    kind = _tag(root).upper()
    version = str(root.attrib.get("version", "")).strip()
    header_el = body = None
    for child in root:
        name = _tag(child)
        if name == "header":
            header_el = child
        elif name == "body":
            body = child
    if body is None:
        raise ValueError(f"{where}: <{_tag(root)}> has no <body> element")
    header = _keywords(header_el) if header_el is not None else {}
    segments: list[tuple[dict[str, str], list[Any]]] = []

    def data_entries(data_el: Any) -> list[Any]:
        return [c for c in data_el if _tag(c) != "COMMENT"]

    pending: dict[str, str] | None = None  # Orekit's <metadata><data> pairs without <segment>
    for child in body:
        name = _tag(child)
        if name == "segment":
            meta_el = next((c for c in child if _tag(c) == "metadata"), None)
            data_el = next((c for c in child if _tag(c) == "data"), None)
            if meta_el is None or data_el is None:
                raise ValueError(f"{where}: a <segment> without <metadata> or <data>")
            segments.append((_keywords(meta_el), data_entries(data_el)))
        elif name == "metadata":
            pending = _keywords(child)
        elif name == "data":
            if pending is None:
                raise ValueError(f"{where}: <data> without the <metadata> before it")
            segments.append((pending, data_entries(child)))
            pending = None
    return XmlMessage(kind, version, header, segments)
