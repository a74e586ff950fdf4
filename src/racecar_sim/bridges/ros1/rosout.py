"""rosout for the roscore racecar-sim starts: a rospy node, run under the interpreter that has rospy.

roscore's own rosout is a roscpp node, and roscpp's XML-RPC server listens on every interface whatever ROS_IP says
(only its TCPROS server honours a loopback ROS_IP); rospy binds both to 127.0.0.1 when ROS_IP is a loopback
address. This node does what rosout does (rosout.cpp): it takes every rosgraph_msgs/Log on /rosout, republishes it on
/rosout_agg and appends it to rosout.log in the run's log folder (ROS_LOG_DIR or ROS_HOME/log, then the /run_id
folder), rotated at 100 MB with 10 backups as rosout's defaults. Like ros_side.py it imports nothing from racecar_sim.
Run as `<ros python> rosout.py __name:=rosout`.
"""

from __future__ import annotations  # the ROS interpreter may be older than the sim's (annotations stay text)

import logging
import logging.handlers
import os
import sys

MAX_FILE_SIZE = 100 * 1024 * 1024  # bytes, rosout's max_file_size default
MAX_BACKUP_INDEX = 10  # rosout's max_backup_index default
LEVELS = {1: "DEBUG", 2: "INFO", 4: "WARN", 8: "ERROR", 16: "FATAL"}


def _log_file() -> logging.Logger | None:
    """rosout.log in the folder roslaunch gives the run's nodes (None if it cannot be made)."""
    import rospkg
    import rospy

    folder = rospkg.get_log_dir()
    run_id = rospy.get_param("/run_id", "")
    if run_id:
        folder = os.path.join(folder, run_id)
    try:
        os.makedirs(folder, exist_ok=True)
        handler = logging.handlers.RotatingFileHandler(
            os.path.join(folder, "rosout.log"), maxBytes=MAX_FILE_SIZE, backupCount=MAX_BACKUP_INDEX
        )
    except OSError:
        return None
    log = logging.getLogger("racecar_sim.rosout")
    log.propagate = False
    log.addHandler(handler)
    return log


def main() -> None:
    import rospy
    from rosgraph_msgs.msg import Log  # type: ignore[import-not-found]  # the ROS interpreter's, not the sim's

    rospy.init_node("rosout", argv=sys.argv, disable_rosout=True, disable_rostime=True)
    aggregate = rospy.Publisher("/rosout_agg", Log, queue_size=100)
    log = _log_file()

    def on_log(msg: Log) -> None:
        aggregate.publish(msg)
        if log is not None:
            log.info(
                "%d.%09d %s %s [%s:%d(%s)] [topics: %s] %s",
                msg.header.stamp.secs,
                msg.header.stamp.nsecs,
                LEVELS.get(msg.level, str(msg.level)),
                msg.name,
                msg.file,
                msg.line,
                msg.function,
                ", ".join(msg.topics),
                msg.msg,
            )

    rospy.Subscriber("/rosout", Log, on_log, queue_size=100)
    rospy.spin()


if __name__ == "__main__":
    main()
