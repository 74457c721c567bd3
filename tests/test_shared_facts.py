"""The C++ client and the Python server agree on what they share: the protocol's version, magic,
header layout, payload limit and message types (stepServerWire.H), the endpoint file's name, the
token's environment variable and the boundary condition's default timeouts (stepServerEndpoint.H),
against adapter/coupling/protocol.py; the default water density (patchLoads.C) against the
scene's. Read from the C++ sources as text, so it needs no compiler;
each check fails when either side changes.
"""

from __future__ import annotations

import re
import struct

import pytest

from adapter.coupling import protocol
from adapter.coupling.protocol import MessageType
from adapter.resources import PLUGIN_SRC

WIRE_H = "client/stepServerWire.H"
ENDPOINT_H = "client/stepServerEndpoint.H"


def _strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def cpp_constants(text: str) -> dict[str, str]:
    """{name: value text} of every ``constexpr <type> name = value;`` (and ``name[] = ...``)."""
    pattern = r"constexpr\s+[\w:\s\*]+?\b(\w+)\s*(?:\[\])?\s*=\s*([^;]+);"
    return {m[1]: m[2].strip() for m in re.finditer(pattern, _strip_comments(text))}


def cpp_enum(text: str, name: str) -> dict[str, int]:
    """{enumerator: value} of ``enum name ... { A = 1, ... }``."""
    m = re.search(r"enum\s+" + name + r"\b[^{]*\{([^}]*)\}", _strip_comments(text))
    assert m, f"enum {name} not found"
    return {k: int(v) for k, v in re.findall(r"(\w+)\s*=\s*(\d+)", m[1])}


def cpp_int(expr: str) -> int:
    """The value of an integer constant: ``2``, or a product such as ``64u*1024u*1024u``."""
    value = 1
    for factor in expr.split("*"):
        m = re.fullmatch(r"\s*(\d+)[uUlL]*\s*", factor)
        assert m, f"not an integer constant: {expr}"
        value *= int(m[1])
    return value


def cpp_string(expr: str) -> str:
    m = re.fullmatch(r'"([^"\\]*)"', expr)
    assert m, expr
    return m[1]


@pytest.fixture(scope="module")
def wire_h() -> dict:
    text = (PLUGIN_SRC / WIRE_H).read_text()
    return {"const": cpp_constants(text), "types": cpp_enum(text, "MsgType")}


@pytest.fixture(scope="module")
def endpoint_h() -> dict[str, str]:
    return cpp_constants((PLUGIN_SRC / ENDPOINT_H).read_text())


def _header_offsets() -> list[int]:
    """Byte offsets of the version, type, length and sequence fields in protocol.HEADER."""
    fmt = protocol.HEADER.format
    order, fields = fmt[0], fmt[1:]
    codes = re.findall(r"\d*[a-zA-Z]", fields)
    return [struct.calcsize(order + "".join(codes[:i])) for i in range(1, len(codes))]


def test_the_protocol_version_and_magic_agree(wire_h):
    c = wire_h["const"]
    assert cpp_int(c["version"]) == protocol.VERSION
    assert cpp_string(c["magic"]).encode() == protocol.MAGIC


def test_the_frame_header_layout_agrees(wire_h):
    c = wire_h["const"]
    assert cpp_int(c["headerSize"]) == protocol.HEADER_SIZE
    offsets = [cpp_int(c[k]) for k in ("versionAt", "typeAt", "lengthAt", "seqAt")]
    assert offsets == _header_offsets()
    assert cpp_int(c["maxPayload"]) == protocol.MAX_PAYLOAD


def test_the_message_types_agree(wire_h):
    assert wire_h["types"] == {t.name: int(t) for t in MessageType}


def test_the_link_facts_and_defaults_agree(endpoint_h):
    assert cpp_string(endpoint_h["endpointFile"]) == protocol.ENDPOINT_NAME
    assert cpp_string(endpoint_h["tokenEnv"]) == protocol.TOKEN_ENV
    assert float(endpoint_h["connectTimeout"]) == protocol.CONNECT_TIMEOUT_S
    assert float(endpoint_h["replyTimeout"]) == protocol.REPLY_TIMEOUT_S


def test_no_other_literal_of_the_shared_facts_in_the_plugin():
    """The plugin writes each shared fact once: in stepServerWire.H / stepServerEndpoint.H."""
    facts = {protocol.ENDPOINT_NAME, protocol.TOKEN_ENV, protocol.SOCKET_NAME,
             protocol.MAGIC.decode()}
    found = []
    for path in sorted(PLUGIN_SRC.rglob("*.[CH]")):
        code = _strip_comments(path.read_text())
        rel = path.relative_to(PLUGIN_SRC).as_posix()
        found += [f"{rel}: {f}" for f in facts
                  if f'"{f}"' in code and rel not in (WIRE_H, ENDPOINT_H)]
    assert found == []


def test_the_plugin_default_density_is_the_scenes():
    """The plugin's rhoInf default (patchLoads.C, for the boundary condition and whaleLoads
    alike) is the scene's default water density, and no other code of the plugin writes it."""
    from adapter.scene import Flow

    code = {p.name: _strip_comments(p.read_text()) for p in sorted(PLUGIN_SRC.rglob("*.[CH]"))}
    m = re.search(r"patchLoads::defaultRhoInf\s*=\s*([\d.eE+-]+)\s*;", code["patchLoads.C"])
    assert m and float(m[1]) == Flow().rho_kg_m3
    assert [name for name, text in code.items() if "1025" in text] == ["patchLoads.C"]


def test_the_parser_reads_what_it_is_given():
    text = """
    // constexpr int commented = 1;
    constexpr char magic[] = "ABCD";
    constexpr std::uint32_t big = 4u*1024u;
    constexpr const char* name = ".x"; /* constexpr int hidden = 2; */
    enum MsgType : std::uint16_t { A = 1, B = 7 };
    """
    c = cpp_constants(text)
    assert c.keys() == {"magic", "big", "name"}
    assert cpp_string(c["magic"]) == "ABCD" and cpp_int(c["big"]) == 4096
    assert cpp_enum(text, "MsgType") == {"A": 1, "B": 7}
