"""A third-party OPC UA client (asyncua) against softplc's OPC UA server.

Usage: client.py URL NAMESPACE_URI PERIOD_MS MODE [CERT_DIR USER PASSWORD]
MODE "full": browse, descriptions, read (types, status codes, timestamps), subscribe, write,
refusals.
MODE "writes-off": a write to a `scada: write` tag is refused when the server's writes are off.
MODE "secure": against a Basic256Sha256 Sign & Encrypt endpoint with a user: SecurityPolicy
None is refused, the client's own certificate (made in CERT_DIR) is trusted by the server once
the test moves it out of the server's rejected/ folder, then USER with PASSWORD reads and a
wrong password is refused.

Speaks to the test on stdout: "PASS step", "FAIL why", "NEED action" (then waits for a line
on stdin once the test has done it), "DONE".
"""

import asyncio
import sys
import time

from pathlib import Path

from asyncua import Client, ua
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256
from cryptography.x509.oid import ExtendedKeyUsageOID

URL, NS_URI, PERIOD_MS, MODE = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
PERIOD = PERIOD_MS / 1000.0


def say(line):
    print(line, flush=True)


class Fail(Exception):
    pass


def check(ok, why):
    if not ok:
        raise Fail(why)


async def need(action):
    say(f"NEED {action}")
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)


class Changes:
    """Data-change notifications, with the time each arrived."""

    def __init__(self):
        self.q = asyncio.Queue()

    def datachange_notification(self, node, val, data):
        self.q.put_nowait((node.nodeid.Identifier, val, time.monotonic()))

    async def wait_for(self, ident, value, within):
        deadline = time.monotonic() + within
        while True:
            left = deadline - time.monotonic()
            check(left > 0, f"no notification {ident} = {value} within {within:.3f} s")
            try:
                got, val, at = await asyncio.wait_for(self.q.get(), left)
            except asyncio.TimeoutError:
                continue
            if got == ident and val == value:
                return at


async def write_status(node, variant):
    """The StatusCode name a write gets."""
    try:
        await node.write_value(ua.DataValue(variant))
        return "Good"
    except ua.UaStatusCodeError as e:
        return ua.StatusCode(e.code).name


async def connect_with_retries():
    deadline = time.monotonic() + 20
    while True:
        c = Client(url=URL, timeout=5)
        try:
            await c.connect()
            return c
        except (OSError, asyncio.TimeoutError, ua.UaError):
            check(time.monotonic() < deadline, f"cannot connect to {URL}")
            await asyncio.sleep(0.1)


async def first_value(node, within=20):
    """The node's value once the server has it from the scan: before its first snapshot the
    server answers BadWaitingForInitialData, as OPC UA says it should."""
    deadline = time.monotonic() + within
    while True:
        try:
            return await node.read_value()
        except ua.UaStatusCodeError as e:
            waiting = e.code == ua.StatusCodes.BadWaitingForInitialData
            check(waiting and time.monotonic() < deadline, f"reading {node}: {e}")
            await asyncio.sleep(PERIOD)


async def full(c):
    ns = await c.get_namespace_index(NS_URI)
    node = lambda ident: c.get_node(ua.NodeId(ident, ns))

    # Browse: the three folders, the tags, a folder per module with its diagnostics.
    names = {(await ch.read_browse_name()).Name: ch for ch in await c.nodes.objects.get_children()}
    for f in ["Tags", "Modules", "PLC"]:
        check(f in names, f"Objects has no {f} folder: {sorted(names)}")
    tags = sorted([(await ch.read_browse_name()).Name for ch in await names["Tags"].get_children()])
    check(
        tags == sorted(["box_at_entry", "start", "motor", "setpoint", "held", "limit", "gain", "far"]),
        f"Tags: {tags}",
    )
    modules = sorted([(await ch.read_browse_name()).Name for ch in await names["Modules"].get_children()])
    check(modules == ["mm1", "mm2", "mm3"], f"Modules: {modules}")
    diag = sorted([(await ch.read_browse_name()).Name for ch in await node("Modules.mm1").get_children()])
    check(diag == ["Errors", "Quality", "Requests", "RoundTrip"], f"mm1's diagnostics: {diag}")
    plc = sorted([(await ch.read_browse_name()).Name for ch in await names["PLC"].get_children()])
    check(plc == sorted(["State", "Scans", "Overruns", "CycleP50", "CycleP99", "CycleMax"]), f"PLC: {plc}")
    say("PASS browse")

    # Descriptions: a tag's and a module's `description:` are their nodes' Description
    # attribute; a tag without one has none.
    async def description(ident):
        try:
            return (await node(ident).read_description()).Text
        except ua.UaStatusCodeError:
            return None
    got = await description("Tags.start")
    check(got == "Start button, green", f"Tags.start's Description: {got!r}")
    got = await description("Modules.mm1")
    check(got == "Conveyor entry, cabinet 1", f"Modules.mm1's Description: {got!r}")
    got = await description("Tags.box_at_entry")
    check(not got, f"Tags.box_at_entry has a Description: {got!r}")
    say("PASS descriptions")
    # The values come with the server's first snapshot of the scan.
    await first_value(node("Tags.setpoint"))

    # Read: exact types, Good, source timestamps from the scan.
    want = {
        "Tags.box_at_entry": ua.VariantType.Boolean,
        "Tags.setpoint": ua.VariantType.UInt16,
        "Tags.limit": ua.VariantType.Int32,
        "Tags.gain": ua.VariantType.Float,
    }
    for ident, vt in want.items():
        dv = await node(ident).read_data_value(raise_on_bad_status=False)
        check(dv.Value.VariantType == vt, f"{ident} is {dv.Value.VariantType}, not {vt}")
        check(dv.StatusCode.is_good(), f"{ident}: {dv.StatusCode}")
        check(dv.SourceTimestamp is not None, f"{ident} has no source timestamp")
        dt = await node(ident).read_data_type_as_variant_type()
        check(dt == vt, f"{ident}'s DataType is {dt}, not {vt}")
    check(await node("Tags.limit").read_value() == -40, "limit is not -40")
    check(await node("Tags.gain").read_value() == 1.5, "gain is not 1.5")
    # A tag of a module nobody answers: its quality is bad.
    dv = await node("Tags.far").read_data_value(raise_on_bad_status=False)
    check(
        dv.StatusCode.value == ua.StatusCodes.BadCommunicationError,
        f"far (module mm3, silent) has {dv.StatusCode}",
    )
    say("PASS read")

    # Diagnostics: the PLC runs and counts its scans, mm1 answers and mm3 does not.
    check(await node("PLC.State").read_value() == "running", "PLC.State is not running")
    s1 = await node("PLC.Scans").read_value()
    await asyncio.sleep(3 * PERIOD + 0.3)
    s2 = await node("PLC.Scans").read_value()
    check(s2 > s1 > 0, f"PLC.Scans does not count: {s1} then {s2}")
    p99 = await node("PLC.CycleP99").read_data_value()
    check(p99.Value.VariantType == ua.VariantType.Double, f"CycleP99 is {p99.Value.VariantType}")
    # mm1 may still be in its start-up (a module found in its own safe state is started
    # again), so it is given a few seconds to be good.
    deadline = time.monotonic() + 10
    while (q := await node("Modules.mm1.Quality").read_value()) != "good":
        check(time.monotonic() < deadline, f"mm1 is not good: {q}")
        await asyncio.sleep(PERIOD)
    check(await node("Modules.mm1.Requests").read_value() > 0, "mm1 has no requests")
    check(await node("Modules.mm3.Quality").read_value() == "bad", "mm3 is not bad")
    check(await node("Modules.mm3.Errors").read_value() > 0, "mm3 has no errors")
    say("PASS diagnostics")

    # Subscribe; a write applied at a cycle boundary is seen within two cycles of its answer.
    changes = Changes()
    sub = await c.create_subscription(PERIOD_MS / 2, changes)
    await sub.subscribe_data_change([node("Tags.setpoint"), node("Tags.start")], sampling_interval=0)
    await asyncio.sleep(2 * PERIOD)
    status = await write_status(node("Tags.setpoint"), ua.Variant(7, ua.VariantType.UInt16))
    check(status == "Good", f"write setpoint = 7: {status}")
    # Counted in the PLC's scans, not in this machine's time: a loaded machine makes cycles
    # late, not more of them. The scan counter itself reaches the server one snapshot late,
    # hence 3.
    done, scans = time.monotonic(), await node("PLC.Scans").read_value()
    at = await changes.wait_for("Tags.setpoint", 7, 5)
    cycles = await node("PLC.Scans").read_value() - scans
    check(cycles <= 3, f"the write was seen {cycles} scans after its answer")
    check(await node("Tags.setpoint").read_value() == 7, "setpoint does not read 7")
    say(f"PASS write seen {1000 * (at - done):.0f} ms ({cycles} scans) after its answer")

    # An input forced at the terminal side of the image is seen within two cycles.
    await need("force start true")
    done, scans = time.monotonic(), await node("PLC.Scans").read_value()
    at = await changes.wait_for("Tags.start", True, 5)
    cycles = await node("PLC.Scans").read_value() - scans
    check(cycles <= 3, f"the forced input was seen {cycles} scans after the force")
    say(f"PASS input change seen {1000 * (at - done):.0f} ms ({cycles} scans) after the force")

    # Refusals: a read-only tag, the wrong type, a forced tag.
    status = await write_status(node("Tags.limit"), ua.Variant(1, ua.VariantType.Int32))
    check(status == "BadUserAccessDenied", f"write to limit (read-only): {status}")
    access = await node("Tags.limit").read_attribute(ua.AttributeIds.UserAccessLevel)
    check(access.Value.Value & 2 == 0, "limit's UserAccessLevel allows writing")
    status = await write_status(node("Tags.setpoint"), ua.Variant(7, ua.VariantType.Int64))
    check(status == "BadTypeMismatch", f"write of an Int64 to setpoint: {status}")
    await need("force held 3")
    status = await write_status(node("Tags.held"), ua.Variant(9, ua.VariantType.UInt16))
    check(status == "BadLocked", f"write to held (forced): {status}")
    await asyncio.sleep(2 * PERIOD)
    check(await node("Tags.held").read_value() == 3, "held does not read its forced value")
    say("PASS refusals")
    await sub.delete()


async def writes_off(c):
    ns = await c.get_namespace_index(NS_URI)
    setpoint = c.get_node(ua.NodeId("Tags.setpoint", ns))
    check(await first_value(setpoint) == 0, "setpoint does not start at 0")
    status = await write_status(setpoint, ua.Variant(7, ua.VariantType.UInt16))
    check(status == "BadUserAccessDenied", f"write with writes off: {status}")
    check(await setpoint.read_value() == 0, "setpoint changed with writes off")
    say("PASS writes off")


CLIENT_URI = "urn:softplc:test:asyncua"


async def secure_client(cert_dir, user, password):
    """A client on Basic256Sha256 Sign & Encrypt with its own certificate and `user`."""
    key, cert = cert_dir / "client-key.pem", cert_dir / "client-cert.der"
    await setup_self_signed_certificate(
        key, cert, CLIENT_URI, "localhost", [ExtendedKeyUsageOID.CLIENT_AUTH], {"commonName": "softplc test"}
    )
    c = Client(url=URL, timeout=5)
    c.application_uri = CLIENT_URI
    await c.set_security(
        SecurityPolicyBasic256Sha256, str(cert), str(key), mode=ua.MessageSecurityMode.SignAndEncrypt
    )
    c.set_user(user)
    c.set_password(password)
    return c


async def refused(c):
    """Whether connecting `c` fails; never leaves it connected."""
    try:
        await c.connect()
    except (OSError, asyncio.TimeoutError, ua.UaError, ConnectionError):
        return True
    await c.disconnect()
    return False


async def secure(cert_dir, user, password):
    # The server is up once its endpoints answer (GetEndpoints needs no secure channel).
    deadline = time.monotonic() + 20
    while True:
        try:
            endpoints = await Client(url=URL, timeout=5).connect_and_get_server_endpoints()
            break
        except (OSError, asyncio.TimeoutError, ua.UaError):
            check(time.monotonic() < deadline, f"no endpoints at {URL}")
            await asyncio.sleep(0.1)
    policies = {(e.SecurityPolicyUri.split("#")[-1], e.SecurityMode.name) for e in endpoints}
    check(policies == {("Basic256Sha256", "SignAndEncrypt")}, f"endpoints: {policies}")
    check(await refused(Client(url=URL, timeout=5)), "SecurityPolicy None was accepted")
    say("PASS none refused")
    c = await secure_client(cert_dir, user, password)
    if await refused(c):
        # A certificate the server does not know yet goes to its rejected/ folder.
        await need("trust")
        c = await secure_client(cert_dir, user, password)
        await c.connect()
    try:
        ns = await c.get_namespace_index(NS_URI)
        gain = await first_value(c.get_node(ua.NodeId("Tags.gain", ns)))
        check(abs(gain - 1.5) < 1e-6, f"gain = {gain} over the encrypted channel")
    finally:
        await c.disconnect()
    say("PASS encrypted read")
    check(await refused(await secure_client(cert_dir, user, password + "x")), "a wrong password was accepted")
    check(await refused(await secure_client(cert_dir, user + "x", password)), "an unknown user was accepted")
    say("PASS wrong password refused")


async def main():
    if MODE == "secure":
        await secure(Path(sys.argv[5]), sys.argv[6], sys.argv[7])
        say("DONE")
        return
    c = await connect_with_retries()
    try:
        await (full(c) if MODE == "full" else writes_off(c))
    finally:
        await c.disconnect()
    say("DONE")


try:
    asyncio.run(main())
except Fail as e:
    say(f"FAIL {e}")
    sys.exit(1)
