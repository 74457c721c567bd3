"""Plant one bug at a time in a copy of the plugin's C++ client and check that
tests/test_client_wire.py fails on each (docs/mutation.md, "The C++ client").

    python scripts/client_bugs.py            # every bug below (about 5 s each)
    python scripts/client_bugs.py 3 7        # only these (numbers as listed)

Each bug is one textual change in stepServerClient.C (the messages), stepServerChannel.C (the
frames) or stepServerStream.C (the socket); the copy is compiled by the test's own fixture
(``WHALE_CLIENT_SRC``). Prints, per bug, the tests that failed; exits 1
if any bug passed every test (or the clean copy fails).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "adapter" / "foam" / "plugin" / "client"
CLIENT = "stepServerClient.C"
CHANNEL = "stepServerChannel.C"
STREAM = "stepServerStream.C"

#: (what, file, original text, planted text)
BUGS = [
    ("ERROR's message dropped", CHANNEL,
     'ctx + ": " + msg);', 'ctx + ": ");'),
    ("ERROR's code not read", CHANNEL,
     "len >= 4 ? getU32(payload.data()) : 0", "0"),
    ("ERROR checked after the type (an ERROR becomes 'unexpected')", CHANNEL,
     "if (type == ERROR)", "if (type == ERROR && type == expected)"),
    ("any newer version accepted", CHANNEL, "if (ver != version)", "if (ver < version)"),
    ("the magic's last byte not checked", CHANNEL,
     "std::memcmp(h, magic, 4) != 0", "std::memcmp(h, magic, 3) != 0"),
    ("NaN in a displacement accepted", CLIENT,
     "!std::isfinite(d[i])", "std::isinf(d[i])"),
    ("WELCOME with trailing bytes accepted", CLIENT, "r.size() != 20", "r.size() < 20"),
    ("WELCOME's point count not checked", CLIENT,
     "w.nPoints != nPoints_", "w.nPoints < nPoints_"),
    ("DISPLACEMENT's time not checked", CLIENT, "if (rt != t)", "if (rt != t && false)"),
    ("DISPLACEMENT's size check only a minimum", CLIENT,
     "r.size() < head || r.size() != expected", "r.size() < expected"),
    ("DISPLACEMENT's frame velocity read from the acceleration's place", CLIENT,
     "getF64(r.data() + 8 + 8 * k)", "getF64(r.data() + 32 + 8 * k)"),
    ("a non-finite frame acceleration accepted", CLIENT,
     "\n            || !std::isfinite(reply.frameAcceleration[k]))", ")"),
    ("DISPLACEMENT's points read from version 2's offset", CLIENT,
     "getF64(r.data() + head + 8 * i)", "getF64(r.data() + 12 + 8 * i)"),
    ("sequence number not checked", CHANNEL, "if (rseq != seq)", "if (false && rseq != seq)"),
    ("sequence numbers from 0", CHANNEL, "const std::uint32_t seq = ++seq_;",
     "const std::uint32_t seq = seq_++;"),
    ("HELLO: nRanks and nPoints swapped", CLIENT,
     "putU32(p, nRanks);\n    putU32(p, std::uint32_t(nPoints_));",
     "putU32(p, std::uint32_t(nPoints_));\n    putU32(p, nRanks);"),
    ("HELLO: the point count in the token length's place", CLIENT,
     "putU32(p, std::uint32_t(token.size()));", "putU32(p, std::uint32_t(nPoints_));"),
    ("REQUEST: viscous force before pressure", CLIENT,
     "{&loads.pressureForce, &loads.viscousForce,", "{&loads.viscousForce, &loads.pressureForce,"),
    ("REQUEST: the moments left out", CLIENT,
     "&loads.pressureMoment,\n          &loads.viscousMoment}", "}"),
    ("payload limit not enforced before reading", CHANNEL,
     "if (len > maxPayload)", "if (len > 2*maxPayload)"),
    ("ACK with a payload accepted", CLIENT, "if (!r.empty())", "if (r.size() > 1)"),
    ("EOF not noticed (waits for the timeout)", STREAM, "if (got == 0)", "if (got == 0 && false)"),
    ("reply timeout ten times too long", STREAM,
     "std::chrono::duration<double>(endpoint_.replyTimeout)",
     "std::chrono::duration<double>(10*endpoint_.replyTimeout)"),
]


def run(src: Path) -> tuple[int, list[str]]:
    env = dict(os.environ, WHALE_CLIENT_SRC=str(src), PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                        "tests/test_client_wire.py"],
                       cwd=ROOT, env=env, capture_output=True, text=True)
    failed = re.findall(r"^FAILED tests/test_client_wire.py::(.+?)(?: - .*)?$", r.stdout, re.M)
    errors = re.findall(r"^ERROR tests/test_client_wire.py::(.+?)(?: - .*)?$", r.stdout, re.M)
    return r.returncode, failed + [f"{e} (error)" for e in errors]


def main(argv: list[str]) -> int:
    chosen = [int(a) for a in argv] or list(range(1, len(BUGS) + 1))
    with tempfile.TemporaryDirectory(prefix="client-bugs-") as tmp:
        clean = Path(tmp) / "clean"
        shutil.copytree(PLUGIN, clean)
        rc, failed = run(clean)
        if rc != 0:
            print(f"the clean client fails: {failed}")
            return 1
        print("clean client: every test passes")
        missed = []
        for i in chosen:
            what, name, old, new = BUGS[i - 1]
            src = Path(tmp) / f"bug{i}"
            shutil.copytree(PLUGIN, src)
            text = (src / name).read_text()
            assert text.count(old) == 1, f"bug {i}: '{old}' not found once in {name}"
            (src / name).write_text(text.replace(old, new))
            rc, failed = run(src)
            caught = rc != 0 and failed
            print(f"{i:2d}. {what}: " + (f"caught by {len(failed)}: {', '.join(failed)}"
                                         if caught else "NOT CAUGHT"), flush=True)
            if not caught:
                missed.append(what)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
