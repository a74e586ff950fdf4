"""`racecar-sim recover BROKEN.mcap [-o FIXED.mcap]`: a valid MCAP of every intact message of a killed recording.

A recording killed with SIGKILL (power loss, the OOM killer) has no summary or footer, and rosbags and the
mcap readers refuse it. This rewrites every record intact up to the first truncated or corrupt one, as
`mcap recover` and `ros2 bag reindex` do, and prints one line saying what was recovered and lost.
"""

from __future__ import annotations

import argparse

from racecar_sim.recording.recover import recover_mcap


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "recover",
        help="rewrite a killed recording (no footer) into a valid MCAP file",
        description="Rewrite every intact message of an MCAP file that has no footer (a run killed "
        "by SIGKILL or power loss) into a valid file; a complete file is rewritten too.",
    )
    p.add_argument("mcap", metavar="BROKEN.mcap", help="the recording to recover")
    p.add_argument(
        "-o",
        "--output",
        metavar="FIXED.mcap",
        help="the file to write (default: BROKEN.recovered.mcap beside the input)",
    )


def main(args: argparse.Namespace) -> int:
    print(recover_mcap(args.mcap, args.output).summary())
    return 0
