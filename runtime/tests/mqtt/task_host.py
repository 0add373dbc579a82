"""What the Sparkplug B host applications of the task tests share: speaking to the Rust test
(stdout: "PASS step", "FAIL why", "DONE"), one MQTT connection subscribed to a group, and the
rebirth command (NCMD Node Control/Rebirth) that makes a running node send its births.
"""

import queue
import sys
import time

import paho.mqtt.client as mqtt


def say(line):
    print(line, flush=True)


def fail(why):
    say(f"FAIL {why}")
    sys.exit(1)


class Host:
    """A host application subscribed to every topic of `group`, on the broker at `port`."""

    def __init__(self, port, group, node, client_id, spb):
        self.ns = f"spBv1.0/{group}"
        self.node = node
        self.spb = spb
        self.messages = queue.Queue()
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=client_id)
        self.client.on_message = lambda c, u, m: self.messages.put((m.topic, m.payload))
        self.client.connect("127.0.0.1", port)
        self.client.subscribe(f"{self.ns}/#", qos=1)
        self.client.loop_start()

    def topic(self, kind, device=None):
        """`spBv1.0/GROUP/KIND/NODE[/DEVICE]`."""
        tail = f"/{device}" if device else ""
        return f"{self.ns}/{kind}/{self.node}{tail}"

    def rebirth(self):
        p = self.spb.Payload()
        m = p.metrics.add()
        m.name = "Node Control/Rebirth"
        m.datatype = 11
        m.boolean_value = True
        self.client.publish(self.topic("NCMD"), p.SerializeToString(), qos=0)

    def birth(self, within=40):
        """The next NBIRTH (parsed), asking for a rebirth every 3 s; fails after `within` s."""
        deadline = time.monotonic() + within
        asked = 0.0
        while True:
            if time.monotonic() > deadline:
                fail("no NBIRTH")
            if time.monotonic() - asked > 3:
                self.rebirth()
                asked = time.monotonic()
            got = self.next(0.5)
            if got is not None and got[0] == self.topic("NBIRTH"):
                return got[1]

    def next(self, timeout):
        """The next message (topic, parsed payload), or None after `timeout` seconds."""
        try:
            topic, raw = self.messages.get(timeout=timeout)
        except queue.Empty:
            return None
        p = self.spb.Payload()
        p.ParseFromString(raw)
        return topic, p

    def stop(self):
        self.client.loop_stop()
