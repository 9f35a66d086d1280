"""Start-up and shutdown of every Florence node.

The executable of a node is two lines::

    #!/usr/bin/python3
    from velocity_filter.node import main; main()

and ``main`` is ``run(VelocityFilterNode, "velocity_filter_node")``. :func:`run`:

1. ``rospy.init_node(name)``;
2. builds the node class (its constructor reads every parameter, through
   :func:`read_params`, creates publishers before subscribers and timers);
3. a bad parameter (``ValueError``, which :class:`ParamError` is) is logged fatal, naming the
   parameter, and the process exits 1; any other start-up failure is logged fatal with its
   traceback and exits 1 too;
4. registers the node's ``shutdown()`` (when it has one) with ``rospy.on_shutdown``:
   nodes that command motion publish a zero command there (:func:`publish_stop`);
5. spins until shutdown.
"""

import sys
import time
import traceback

import rospy


def read_params(table, namespace=None):
    """Values of ``table`` (florence_common.params.ParamTable) from the parameter server, its
    names resolved below ``namespace`` (default: the table's prefix, the node's private namespace
    unless the table says otherwise), e.g. "~NavfnROS/". Raises ParamError."""
    prefix = table.prefix if namespace is None else namespace
    return table.read(lambda name, default: rospy.get_param(prefix + name, default))


def publish_stop(publisher, wait=0.05):
    """Publish one zero geometry_msgs/Twist on ``publisher`` and give it ``wait`` [s, wall]
    to leave (a node's last command before it exits)."""
    from geometry_msgs.msg import Twist

    try:
        publisher.publish(Twist())
        time.sleep(wait)
    except rospy.ROSException:  # already shut down: nothing more can be sent
        pass


def build(node_class, name, *args, **kwargs):
    """Construct ``node_class(*args, **kwargs)`` after init_node; fatal log and exit 1 when it
    cannot start. Returns the node."""
    try:
        node = node_class(*args, **kwargs)
    except ValueError as exc:  # ParamError is one
        rospy.logfatal("%s: bad parameter: %s", name, exc)
        sys.exit(1)
    except Exception as exc:  # noqa: BLE001 - any start-up failure ends the node with its cause
        rospy.logfatal("%s: cannot start: %s\n%s", name, exc, traceback.format_exc())
        sys.exit(1)
    shutdown = getattr(node, "shutdown", None)
    if callable(shutdown):
        rospy.on_shutdown(shutdown)
    return node


def run(node_class, name, *args, anonymous=False, **kwargs):
    """init_node, build ``node_class``, spin (see the module docstring). Returns the node after
    shutdown."""
    rospy.init_node(name, anonymous=anonymous)
    node = build(node_class, name, *args, **kwargs)
    rospy.spin()
    return node
