"""Service calls that always end: asynchronous, bounded, and with a reason when they fail.

A service call is a request sent now and a response that arrives later, delivered by
an executor spinning the calling node. ``call`` sends the request with ``call_async``
and spins until the future is done or a deadline passes, so neither a missing server
nor a server that never answers can hang a notebook, a check or the CLI.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from rosbook.runtime.executors import MultiThreadedExecutor
from rosbook.runtime.interfaces import interface_name
from rosbook.runtime.session import spin_node_until

#: Wall-clock bound for discovering a server (seconds).
DISCOVERY_TIMEOUT_S = 2.0


class ServiceCallError(RuntimeError):
    """A call that got no response: no server, or no answer before the deadline."""


class ServiceTimeout(ServiceCallError, TimeoutError):
    """A call whose wall-clock limit passed: no server appeared, or none answered, in
    time. On a loaded machine that is not proof that none would have: a check given
    this reports a timeout, never a wrong answer."""


def wait_for_server(client: Any, name: str, timeout: float = DISCOVERY_TIMEOUT_S) -> None:
    """Wait until ``client`` (service or action) sees a server, or say there is none."""
    ready = (
        client.wait_for_service if hasattr(client, "wait_for_service") else client.wait_for_server
    )
    if not ready(timeout_sec=timeout):
        raise ServiceTimeout(f"no server for '{name}' appeared within {timeout:g} s")


def call(
    node: Node,
    srv_type: type,
    service: str,
    request: Any = None,
    *,
    timeout: float = 2.0,
) -> Any:
    """Call ``service`` from ``node`` and return the response (bounded by ``timeout``).

    Raises ``ServiceTimeout`` (a ``ServiceCallError``) naming the service and its type
    when no server is found or none answers in time. The client is destroyed afterwards.
    """
    client = node.create_client(srv_type, service)
    full_name = node.resolve_service_name(service)
    try:
        wait_for_server(client, f"{full_name} ({interface_name(srv_type)})", timeout)
        future = client.call_async(srv_type.Request() if request is None else request)
        if not spin_node_until(node, future.done, timeout):
            client.remove_pending_request(future)
            raise ServiceTimeout(
                f"'{full_name}' ({interface_name(srv_type)}) did not answer within "
                f"{timeout:g} s: is its server's node being spun?"
            )
        return future.result()
    finally:
        node.destroy_client(client)


@dataclass
class Returned:
    """What a function run under a deadline did: its value, or that it never returned."""

    finished: bool
    value: Any = None
    error: BaseException | None = None
    seconds: float = 0.0


def run_with_deadline(function: Callable[[], Any], deadline_s: float) -> Returned:
    """Run ``function`` in a daemon thread and stop waiting for it after ``deadline_s``.

    A function stuck forever (a synchronous call nobody will answer) cannot be killed,
    but the caller gets control back and can report it; the thread ends if the wait it
    is stuck in ever completes.
    """
    outcome = Returned(finished=False)
    start = time.monotonic()

    def target() -> None:
        try:
            outcome.value = function()
        except BaseException as exc:  # reported to the caller, not raised in a thread
            outcome.error = exc
        outcome.seconds = time.monotonic() - start
        outcome.finished = True

    thread = threading.Thread(target=target, name="deadline", daemon=True)
    thread.start()
    thread.join(deadline_s)
    if not outcome.finished:
        outcome.seconds = time.monotonic() - start
    return outcome


class BackgroundServer:
    """A service server of the test's own, in a context and a thread of its own.

    It answers while the calling thread is blocked or spins only its own node, like a
    server in another process would, without the start-up time of a process.
    ``handler(request, response) -> response`` is the service callback; one that makes
    the caller wait should wait on ``stopping`` so that ``close()`` ends it at once.
    """

    def __init__(
        self,
        srv_type: type,
        service: str,
        handler: Callable[[Any, Any], Any],
        node_name: str = "check_server",
    ) -> None:
        self.context = Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node(node_name, context=self.context, start_parameter_services=False)
        self.calls = 0
        self.stopping = threading.Event()
        # Handlers run in the executor's two worker threads: the counters are guarded.
        self._busy = 0
        self._idle = threading.Condition()

        def counted(request: Any, response: Any) -> Any:
            with self._idle:
                self.calls += 1
                self._busy += 1
            try:
                return handler(request, response)
            finally:
                with self._idle:
                    self._busy -= 1
                    self._idle.notify_all()

        self.service = self.node.create_service(srv_type, service, counted)
        self.executor = MultiThreadedExecutor(num_threads=2, context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name=node_name, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # the context was shut down under it: the server is closing
            pass

    def close(self) -> None:
        """Stop serving and release the context (safe to repeat)."""
        if not self.context.ok():
            return
        self.stopping.set()
        # rclpy's executor.shutdown() does not wait for callbacks in flight: let any
        # handler return and its response go out before the service is destroyed.
        with self._idle:
            self._idle.wait_for(lambda: self._busy == 0, timeout=2.0)
        time.sleep(0.05)
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)
        self._thread.join(timeout=1.0)

    def __enter__(self) -> BackgroundServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
