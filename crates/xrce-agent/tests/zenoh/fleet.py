"""The fleet test (docs/zenoh.md, "Fleets"): run by scripts/zenoh-fleet.sh inside the "ground" namespace, with
root, after it made one namespace per robot joined to ground by a veth pair (198.18.<i>.1 ground side,
198.18.<i>.2 robot side). Here: a Zenoh router (`peer.py router`) and a ROS-like checker (peer.py's Node);
per robot, `xrce-agent -m zenoh` and a micro-ROS-like node (`micro_ros_node`, node `uav_<i>/px4_like`,
publishing `/uav_<i>/fmu/out/vehicle_status`) started in the robot's namespace. Checks: the ground sees every
robot's node and data, each robot's data only under its own namespace, with its own publisher's GID; robot 1's
link cut: its node and endpoints leave, the others stay; restored: they come back, once (no ghost). Measures the
router's memory and CPU with 0..N robots. Prints FLEET lines; exits 1 on the first failed check.

  fleet.py ROBOTS AGENT_BIN MICRO_ROS_NODE_BIN NS_PREFIX
"""

import json
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peer  # noqa: E402

LEASE_MS = "2000"
STRING = "std_msgs::msg::dds_::String_"
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
WINDOW = 5.0


def say(**fields):
    print("FLEET " + json.dumps(fields, sort_keys=True), flush=True)


PROCS = []


def stop(code):
    """Ends the run: the processes started, then this one (os._exit: Zenoh's threads would keep it alive)."""
    for p in reversed(PROCS):
        p.kill()
        p.wait()
    sys.stdout.flush()
    os._exit(code)


def fail(what, **fields):
    say(failed=what, **fields)
    stop(1)


def router_cost(pid):
    """The router's resident memory (KiB) and CPU share over WINDOW seconds."""
    def ticks():
        with open("/proc/%d/stat" % pid) as f:
            parts = f.read().rsplit(")", 1)[1].split()
        return int(parts[11]) + int(parts[12])
    start = ticks()
    time.sleep(WINDOW)
    cpu = (ticks() - start) / os.sysconf("SC_CLK_TCK") / WINDOW
    with open("/proc/%d/status" % pid) as f:
        rss = next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))
    return {"rss_kib": rss, "cpu_percent": round(100 * cpu, 2)}


def main():
    robots, agent_bin, node_bin, prefix = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
    env = dict(os.environ, ZENOH_LEASE_MS=LEASE_MS)
    procs = PROCS
    try:
        router = subprocess.Popen([sys.executable, peer.__file__, "router", "tcp/0.0.0.0:7447"], env=env,
                                  stdout=subprocess.PIPE)
        procs.append(router)
        router.stdout.readline()
        os.environ["ZENOH_LEASE_MS"] = LEASE_MS
        ground = peer.Node("tcp/127.0.0.1:7447")
        costs = [dict(robots=0, **router_cost(router.pid))]
        say(step="router", **costs[0])
        tokens, gids = {}, {}
        for i in range(1, robots + 1):
            ns = "%s%d" % (prefix, i)
            config = tempfile.NamedTemporaryFile("w", suffix=".json5", delete=False)
            # A client of the ground's router, as docs/zenoh.md tells robots to be: rmw_zenohd's stock router
            # does not broker between peers (peers_failover_brokering: false, as peer.py's router), so a robot in
            # peer mode would reach a ground node only if each could connect to the other.
            config.write('{ mode: "client", connect: { endpoints: ["tcp/198.18.%d.1:7447"] }, '
                         'scouting: { multicast: { enabled: false } }, '
                         'transport: { link: { tx: { lease: %s } } } }' % (i, LEASE_MS))
            config.close()
            procs.append(subprocess.Popen(
                ["ip", "netns", "exec", ns, agent_bin, "udp4", "-p", "8888", "-m", "zenoh", "-v", "3",
                 "--zenoh-config", config.name], stdout=subprocess.DEVNULL))
            time.sleep(0.5)
            procs.append(subprocess.Popen(
                ["ip", "netns", "exec", ns, node_bin, "--port", "8888", "--key", str(0x7100 + i),
                 "--node", "uav_%d/px4_like" % i, "--pub", "uav_%d/fmu/out/vehicle_status" % i,
                 "--count", "1000000", "--period-ms", "100", "--run-for-s", "600"], stdout=subprocess.DEVNULL))
            node = ground.cmd_wait_token("/NN/%%/%%uav_%d/px4_like" % i, "present")
            pub = ground.cmd_wait_token("/MP/%%/%%uav_%d/px4_like/%%uav_%d%%fmu%%out%%vehicle_status/" % (i, i), "present")
            if not (node["ok"] and pub["ok"]):
                fail("robot %d not in the graph" % i, node=node, pub=pub)
            tokens[i], gids[i] = pub["tokens"][0], peer.gid_of(pub["tokens"][0]).hex()
            key = "0/uav_%d/fmu/out/vehicle_status/%s/%s" % (i, STRING, STRING_HASH)
            ground.cmd_sub("uav_%d" % i, key)
            got = ground.cmd_take("uav_%d" % i, 3)
            if not got["ok"] or any(s["attachment"]["gid"] != gids[i] for s in got["samples"]):
                fail("robot %d's data" % i, got=got)
            costs.append(dict(robots=i, **router_cost(router.pid)))
            say(step="robot %d joined" % i, **costs[-1])

        # Namespaces kept apart: each robot's key carried its own publisher only.
        for i in range(1, robots + 1):
            foreign = [s for s in ground.samples["uav_%d" % i] if s["attachment"]["gid"] != gids[i]]
            if foreign:
                fail("samples of another robot under uav_%d" % i, foreign=foreign[:3])

        # Robot 1's link cut: its node and endpoints leave the graph, the others stay.
        cut = "%s1" % prefix
        subprocess.run(["ip", "-n", cut, "link", "set", "up0", "down"], check=True)
        started = time.time()
        gone = ground.cmd_wait_token("%uav_1/px4_like", "absent")
        left_s = time.time() - started
        others = [ground.cmd_wait_token("/NN/%%/%%uav_%d/px4_like" % i, "present") for i in range(2, robots + 1)]
        if not gone["ok"] or not all(o["ok"] for o in others):
            fail("cut link", gone=gone, others=others)
        subprocess.run(["ip", "-n", cut, "link", "set", "up0", "up"], check=True)
        started = time.time()
        back = ground.cmd_wait_token("/MP/%/%uav_1/px4_like/", "present")
        back_s = time.time() - started
        nodes = ground.cmd_wait_token("/NN/%/%uav_1/px4_like", "present")
        if not back["ok"] or len(nodes["tokens"]) != 1 or len(back["tokens"]) != 1:
            fail("restored link: robot 1 once", back=back, nodes=nodes)
        before = len(ground.samples["uav_1"])
        again = ground.cmd_take("uav_1", before + 3)
        if not again["ok"]:
            fail("robot 1's data after the link came back", samples=len(ground.samples["uav_1"]))
        say(step="link cut and restored", left_after_s=round(left_s, 1), back_after_s=round(back_s, 1),
            tokens_of_robot1=len([t for t in ground.tokens if "uav_1" in t]))
        per_robot = (costs[-1]["rss_kib"] - costs[0]["rss_kib"]) / max(robots, 1)
        say(summary="ok", robots=robots, router=costs, rss_kib_per_robot=round(per_robot))
    except Exception as e:  # a failed step of its own
        fail("%s: %s" % (type(e).__name__, e))
    stop(0)


if __name__ == "__main__":
    main()
