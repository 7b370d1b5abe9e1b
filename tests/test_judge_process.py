"""The judge process's life around one submission: started early, ended promptly.

Grading speed depends on both: the judge starts (interpreter, rclpy, ROS) while the
kernel starts rather than at the first judged cell, and it ends as soon as its stdin
closes instead of asking the already shut-down kernel for a last "stop".
"""

from __future__ import annotations

import json
import threading
from pathlib import Path

from autograder import judge, sandbox
from autograder.verdicts import judging
from rosbook.runtime.session import Session


def test_the_judge_starts_with_the_submission_before_any_cell() -> None:
    with sandbox.Network() as network, sandbox.using(network):
        with judging("lab01_nodes_topics") as run:
            process = run.process
            assert process is not None and process.poll() is None
            assert run.verdicts == {}
        assert run.process is None and process.poll() is not None  # ended with the block


def test_an_assignment_without_judged_checks_starts_no_judge() -> None:
    """Every lab of the course is judged; an assignment an instructor adds without a
    judge module (its test cells score in the kernel, as nbgrader's do) costs none."""
    assert judge.judged_checks("lab99_new") == {}
    with judging("lab99_new") as run:
        assert run.process is None


def test_closing_a_kernel_sends_it_nothing(tmp_path: Path) -> None:
    """When the judge's stdin closes, the kernel is already gone: a last call would
    only wait out its guard (10 s per submission, every submission)."""
    connection = tmp_path / "kernel.json"
    connection.write_text(
        json.dumps(
            {
                "transport": "ipc",
                "ip": str(tmp_path / "k"),
                "shell_port": 1,
                "iopub_port": 2,
                "stdin_port": 3,
                "control_port": 4,
                "hb_port": 5,
                "key": "",
                "signature_scheme": "hmac-sha256",
            }
        )
    )
    kernel = judge.Kernel(str(connection))
    kernel.agent_ready = True  # as after a check: the agent was defined
    sent: list[dict] = []
    kernel.client.session.send = lambda *a, **k: sent.append({"args": a})  # type: ignore[method-assign]
    kernel.close()
    assert sent == []


def test_a_kernel_says_which_subscriptions_its_node_can_send_to(session: Session) -> None:
    """A publisher sends only to the subscriptions its own participant has discovered;
    the judge's side matching says nothing of that (each side discovers on its own), and
    a message sent before is lost, not late: lab 3's judge lost an action's first
    feedback that way. While following the judge's /clock the kernel names, in its acks,
    the subscriptions its node discovered on each topic it sends on, and the judge waits
    to be among them before time moves."""
    from jupyter_client import KernelManager
    from std_msgs.msg import Int64, String

    from autograder.judge_lab01 import _ack, wait_until_discovered

    km = KernelManager()
    km.start_kernel()
    kernel = None
    try:
        setup = km.client()
        setup.start_channels()
        setup.wait_for_ready(timeout=60)
        reply = setup.execute_interactive(
            "from rclpy.node import Node\n"
            "from std_msgs.msg import Int64\n"
            "class Talker(Node):\n"
            "    def __init__(self):\n"
            "        super().__init__('talker')\n"
            "        self.pub = self.create_publisher(Int64, 'counter', 10)\n",
            timeout=60,
        )
        assert reply["content"]["status"] == "ok", reply["content"]
        setup.stop_channels()
        kernel = judge.Kernel(km.connection_file)
        assert kernel.call("start", "Talker", {}, True)["name"] == "talker"
        node = judge.ros_node("judge_listener")
        acked = [_ack("")]
        node.create_subscription(
            String, "/rosbook_judge/clock_ack", lambda m: acked.append(_ack(m.data)), 10
        )
        following = kernel.send("follow_clock", 1.0, 60.0)
        assert session.spin_until(lambda: acked[-1]["now"] >= 0, node, timeout=60)
        assert acked[-1]["readers"] == {"/counter": set()}  # nobody listens yet
        node.create_subscription(Int64, "/counter", lambda m: None, 10)
        wait_until_discovered(acked, node, "/counter", "judge_listener", "talker")
        (mine,) = node.get_subscriptions_info_by_topic("/counter")
        assert acked[-1]["readers"]["/counter"] == {bytes(mine.endpoint_gid).hex()}
        clock = judge.clock_publisher(node)
        done: list = []
        waiter = threading.Thread(target=lambda: done.append(kernel.answer(following, 60)))
        waiter.start()
        while waiter.is_alive():
            clock.publish(judge.clock_message(1.0))
            session.spin_until(lambda: False, node, timeout=0.2)
        assert done == [{"timeout": False}]
    finally:
        if kernel is not None:
            kernel.client.stop_channels()
        km.shutdown_kernel(now=True)
