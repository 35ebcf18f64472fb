"""
The one place the nodes reach below rclpy's public API: the crowd's fast path.

A node serving thousands of agents cannot let an executor wake once per
truth message, nor pay rclpy's per-message checks on every fix: at 1,000
agents the executor's pass over the subscriptions alone cost 0.4 ms per
wake, and ``Publisher.publish``'s guard and type check 1-3 us per message
(decision 0030). What the fast path needs, and nothing else, is here:

* :class:`DrainedByTheNode`, a callback group no executor runs, and
  :class:`WaitsOnUndrained`, a node mixin whose ``subscriptions`` (the
  public property executors build their wait set from) leaves the drained
  ones out;
* :func:`take_raw`, a subscription's next serialized message taken from its
  handle (rclpy has no public take outside an executor);
* :func:`publish_raw`, serialized bytes published on a publisher's handle.

``test/ros/test_rclpy_adapter.py`` checks each of these against the
installed rclpy (:data:`RCLPY_TESTED`), so that a change underneath fails
there, by name, rather than as a silent slowdown or lost messages.
"""

from collections.abc import Iterator
from typing import Any, TYPE_CHECKING

from rclpy.callback_groups import CallbackGroup

if TYPE_CHECKING:       # the mixin's super() is a Node's
    from rclpy.node import Node as _NodeBase
else:
    _NodeBase = object

#: The rclpy release the adapter was written and tested against (ros-jazzy-rclpy).
RCLPY_TESTED = '7.1.6'


class DrainedByTheNode(CallbackGroup):
    """
    A callback group whose members no executor runs.

    A crowd's truth subscriptions: the node takes their messages itself,
    all of them once per step, and does not list them in its
    ``subscriptions`` (:class:`WaitsOnUndrained`), so executors do not even
    pass over them (at 1,000 agents that pass cost 0.4 ms per wake, 3.9 ms
    at 5,000).
    """

    def can_execute(self, entity: Any) -> bool:
        """Return False: an executor never runs the entity."""
        return False

    def beginning_execution(self, entity: Any) -> bool:
        """Return False: an executor never begins to run the entity."""
        return False

    def ending_execution(self, entity: Any) -> None:
        """Do nothing: an executor never ran the entity."""


class WaitsOnUndrained(_NodeBase):
    """
    A node mixin: executors wait on its subscriptions except those in ``self.drained``.

    The drained ones (a :class:`DrainedByTheNode` group) stay in rclpy's own
    list, so that ``destroy_node`` destroys them, but :attr:`subscriptions`
    leaves them out.
    """

    def create_subscription(self, *args: Any, **kwargs: Any) -> Any:
        """Create a subscription (rclpy's); executors wait on it unless it is drained."""
        sub = super().create_subscription(*args, **kwargs)
        if sub.callback_group is not getattr(self, 'drained', None):
            self.__dict__.setdefault('waited_on', []).append(sub)
        return sub

    def destroy_subscription(self, subscription: Any) -> bool:
        """Destroy a subscription created by the node (rclpy's); True if it was."""
        waited = self.__dict__.get('waited_on', [])
        if subscription in waited:
            waited.remove(subscription)
        return super().destroy_subscription(subscription)

    @property
    def subscriptions(self) -> Iterator[Any]:
        """Yield the subscriptions executors wait on: not the drained ones."""
        yield from list(self.__dict__.get('waited_on', ()))


def handles(subscription: Any) -> tuple[Any, Any]:
    """Return what :func:`take_raw` needs of a subscription: (its handle, its type)."""
    return subscription.handle, subscription.msg_type


def take_raw(handle: Any, msg_type: Any) -> bytes | None:
    """
    Return the next serialized message waiting on a subscription's ``handle``, or None.

    The handle is used as it is, without rclpy's context-manager guard: the
    caller owns the subscription and does not destroy it while taking.
    """
    taken = handle.take_message(msg_type, True)
    return None if taken is None else taken[0]


def take_message(subscription: Any) -> Any:
    """
    Return the next message waiting on ``subscription`` (serialized if it is raw), or None.

    Guarded as rclpy guards its own use of the handle; for a node that
    takes what an executor has not yet (a fit or a shutdown that must see
    every message already received).
    """
    with subscription.handle:
        taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
    return None if taken is None else taken[0]


def publish_raw(handle: Any, data: bytes) -> None:
    """Publish serialized ``data`` on a publisher's ``handle`` (``Publisher.handle``)."""
    handle.publish_raw(data)
