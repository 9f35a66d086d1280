# Sourced by devel/setup.bash. ROS 1 on Debian lives in Debian's python3; nodes with
# `#!/usr/bin/env python3` (e.g. Debian's joint_state_publisher) break when another
# python3 (pyenv, conda) comes first on PATH. Put /usr/bin first only in that case.
if [ "$(command -v python3 2>/dev/null)" != "/usr/bin/python3" ] && \
   ! python3 -c 'import rospy' >/dev/null 2>&1; then
  PATH="/usr/bin:$PATH"
  export PATH
fi
