"""What a bench measures of the processes it starts: a node's process id (through the master)
and its CPU time (from /proc). Linux only; no rospy."""

import os
import xmlrpc.client


def node_pid(master_uri, name, caller="/bench"):
    """Process id of the ROS node ``name`` (e.g. "/move_base") registered with the master at
    ``master_uri``."""
    master = xmlrpc.client.ServerProxy(master_uri)
    _, _, uri = master.lookupNode(caller, name)
    return xmlrpc.client.ServerProxy(uri).getPid(caller)[2]


def cpu_seconds(pid):
    """User + system CPU time [s] of process ``pid`` so far."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def memory_kib(pid):
    """{"VmRSS": resident set, "VmHWM": its peak} [KiB] of process ``pid``."""
    fields = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                fields[key] = int(value.split()[0])
    return fields
