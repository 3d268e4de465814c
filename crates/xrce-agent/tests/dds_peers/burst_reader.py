"""A reliable HelloWorld reader for the first-contact burst test (tests/dds_interop.rs). It prints `ready` once
its reader exists and Cyclone has discovered another participant (the agent's, the only other one), so the test
starts its client against a reader that is really running, however slowly Python starts on the machine; then
it prints `received index=<i>` per sample until it has N or SECS have passed.
usage: python burst_reader.py SECS N"""
import sys
import time
from dataclasses import dataclass

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
import cyclonedds.idl.types as t
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class HelloWorld(IdlStruct, typename="HelloWorld"):
    index: t.uint32
    message: str


secs, n = float(sys.argv[1]), int(sys.argv[2])
qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepAll)
dp = DomainParticipant(0)
reader = DataReader(dp, Topic(dp, "HelloWorldTopic", HelloWorld, qos=qos), qos=qos)
participants = BuiltinDataReader(dp, BuiltinTopicDcpsParticipant)
t0 = time.time()
agent_seen = False
while not agent_seen and time.time() - t0 < secs:
    agent_seen = any(s.key != dp.guid for s in participants.take(N=64))
    time.sleep(0.02)
print("ready" if agent_seen else "agent participant not seen", flush=True)
got = 0
while time.time() - t0 < secs and got < n:
    for s in reader.take(10):
        got += 1
        print(f"received index={s.index}", flush=True)
    time.sleep(0.02)
print("received total", got, flush=True)
sys.exit(0 if got == n else 1)
