"""Prints the name (PID_ENTITY_NAME) of every DDS participant Cyclone DDS discovers in domain 0 within the
given seconds, one `participant name=<name>` line each (`<none>` for an unnamed one). Run with the Cyclone
venv of .ci/dds-peers.sh; used by tests/dds_interop.rs."""
import sys
import time

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Policy

seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 3.0
dp = DomainParticipant(0)
reader = BuiltinDataReader(dp, BuiltinTopicDcpsParticipant)
seen = set()
deadline = time.time() + seconds
while time.time() < deadline:
    for s in reader.take(N=64):
        try:
            name = s.qos[Policy.EntityName].name
        except (KeyError, TypeError, AttributeError):
            name = "<none>"
        if (s.key, name) not in seen:
            seen.add((s.key, name))
            print(f"participant name={name}", flush=True)
    time.sleep(0.05)
