"""
The error node's ``agent_pattern``: which truth topics in the graph are agents.

A pattern is a topic name with one ``*`` standing for one whole name segment
(``/peds/*/pose``). A topic matches when it has the pattern's segments with
any ROS name token (letters, digits and ``_``, not starting with a digit) in
the ``*``'s place; that token is the agent's name, which keys its error
stream exactly as an entry of ``agents`` would, and its fixes go on the
matched topic with the last segment replaced by ``fix``.
"""

from collections.abc import Callable, Collection, Mapping, Sequence
import re
from typing import Any, TYPE_CHECKING

import numpy as np

from gps_error_ros.model.state import IntArray
from gps_error_ros.model.streams import agent_key
from gps_error_ros.ros import conversions
from gps_error_ros.ros.parameters import ConfigError

from gps_error_ros.ros.profile_group import ProfileGroup

if TYPE_CHECKING:       # the mixin's super() is a Node's
    from rclpy.node import Node as _NodeBase
else:
    _NodeBase = object

TOKEN = r'[A-Za-z_][A-Za-z0-9_]*'


class AgentPattern:
    """
    A parsed ``agent_pattern`` (see the module docstring).

    Parameters
    ----------
    pattern
        The pattern; a relative one is taken in ``namespace``.
    namespace
        The node's namespace.
    msg_type
        The truth message's ROS type name (``geometry_msgs/msg/PoseStamped``);
        topics of other types are not agents.

    Raises
    ------
    ConfigError
        Naming the pattern and what a pattern must be.

    """

    def __init__(self, pattern: str, namespace: str, msg_type: str) -> None:
        text = pattern.strip()
        if not text.startswith('/'):
            text = namespace.rstrip('/') + '/' + text
        segments = text.split('/')[1:]
        problem = None
        if segments.count('*') != 1:
            problem = 'exactly one * standing for a whole name segment'
        elif segments[-1] == '*':
            problem = 'a segment after the * (the truth topic, e.g. /peds/*/pose)'
        elif not all(s == '*' or re.fullmatch(TOKEN, s) for s in segments):
            problem = 'segments of letters, digits and _ (not starting with a digit)'
        if problem:
            raise ConfigError(f'parameter \'agent_pattern\': invalid value {pattern!r}: '
                              f'expected {problem}')
        self.text = text
        self.msg_type = msg_type
        star = segments.index('*')
        parts = [re.escape(s) if s != '*' else f'({TOKEN})' for s in segments]
        self.regex = re.compile('/' + '/'.join(parts) + '$')
        self.fix_segments = segments[:-1] + ['fix']
        self.star = star
        self.misses: set[str] = set()         # topic names seen not to match

    def fix_topic(self, name: str) -> str:
        """Return the fix topic of agent ``name``."""
        segments = list(self.fix_segments)
        segments[self.star] = name
        return '/' + '/'.join(segments)

    def scan(self, names_and_types: Sequence[tuple[str, Sequence[str]]],
             skip: Collection[str] = ()) -> tuple[dict[str, str], list[str]]:
        """
        Return ({agent: truth topic}, [topics of the wrong type]) in the graph.

        ``names_and_types`` as ``Node.get_topic_names_and_types()`` gives it;
        topics in ``skip`` (those already known) are passed over, and so are
        topics that did not match before (remembered in ``misses``).
        """
        agents: dict[str, str] = {}
        wrong: list[str] = []
        if len(self.misses) > 2 * len(names_and_types) + 1000:
            self.misses.clear()     # bounded over hours of topics that come and go
        for topic, types in names_and_types:
            if topic in skip or topic in self.misses:
                continue
            m = self.regex.match(topic)
            if not m:
                self.misses.add(topic)
                continue
            if self.msg_type in types:
                agents[m.group(1)] = topic
            else:
                wrong.append(f'{topic} ({", ".join(types)})')
        return agents, wrong


class AgentWatcher:
    """
    Serve the agents whose truth topics match a pattern, as they come and go.

    Works on an error node in pattern mode (one profile group over slots).
    :meth:`scan` runs once a second of wall time: new matching topics get a
    slot (the engine grows by doubling when none is free), a subscription and
    a publisher; agents stale for ``timeout_s`` of the ROS clock whose topic
    has no publisher left are released. The engine's catch-up runs once at
    construction, so that the first agent does not stop the node for the
    imports the catch-up needs.
    """

    def __init__(self, node: 'PatternAgents', pattern: AgentPattern, timeout_s: float) -> None:
        self.node = node
        self.pattern = pattern
        self.timeout_ns = int(round(timeout_s * 1e9))
        self.index: dict[str, int] = {}             # agent name -> slot
        self.topics: dict[str, str] = {}            # agent name -> its truth topic
        self.attached = np.zeros(0, dtype=np.int64)   # slot -> ROS time (ns) served from
        self._served: frozenset[str] | None = None  # self.topics' values, when current
        self.warned: set[str] = set()
        self.stale = 0
        self.released = 0
        node.prepare_attach()

    def scan(self) -> None:
        """Serve new agents and release departed ones."""
        node = self.node
        # the served agents' topics are skipped: a pass costs little beyond the
        # listing itself, however many agents are served
        found, wrong = self.pattern.scan(node.get_topic_names_and_types(),
                                         skip=self._served_topics())
        for topic in wrong:
            if topic not in self.warned:
                self.warned.add(topic)
                node.get_logger().warning(
                    f'agent_pattern {self.pattern.text}: {topic} matches but is not '
                    f'of type {self.pattern.msg_type}: not served')
        new = [(name, topic) for name, topic in sorted(found.items())
               if name not in self.index]
        if new:
            slots = node.open_agents(new, [self.pattern.fix_topic(n) for n, _ in new])
            now = node.now_ns()
            self._grow(max(slots) + 1)
            for (name, topic), slot in zip(new, slots):
                self.index[name] = slot
                self.topics[name] = topic
                self.attached[slot] = now
            self._served = None
            shown = ', '.join(n for n, _ in new[:5]) + (' ...' if len(new) > 5 else '')
            node.get_logger().info(f'serving {len(new)} new agent(s): {shown}')
        gone = self._departed(node.now_ns())
        if gone:
            node.close_agents([self.index.pop(name) for name in gone])
            for name in gone:
                del self.topics[name]
            self._served = None
            self.released += len(gone)
            shown = ', '.join(gone[:5]) + (' ...' if len(gone) > 5 else '')
            node.get_logger().info(f'released {len(gone)} departed agent(s): {shown}')

    def _served_topics(self) -> frozenset[str]:
        """Return the set of served agents' truth topics (rebuilt after a change)."""
        if self._served is None:
            self._served = frozenset(self.topics.values())
        return self._served

    def _grow(self, size: int) -> None:
        """Make room for slot indices below ``size``."""
        if size > self.attached.size:
            self.attached = np.r_[self.attached,
                                  np.zeros(size - self.attached.size, dtype=np.int64)]

    def _departed(self, now: int) -> list[str]:
        """Return the names of stale agents with no publisher left; count stale ones."""
        if now <= 0 or not self.index:
            self.stale = 0
            return []
        newest = np.asarray(self.node.newest_truth_ns(), dtype=np.int64)
        names = list(self.index)
        slots = np.fromiter(self.index.values(), dtype=np.int64, count=len(names))
        self._grow(int(slots.max()) + 1)
        since = self.attached[slots]
        reset = (since <= 0) | (since > now)       # no clock yet, or it went back
        self.attached[slots[reset]] = now
        last = np.maximum(newest[slots], since)
        gone: list[str] = []
        stale = 0
        for i in np.flatnonzero(~reset & (now - last > self.timeout_ns)):
            slot = int(slots[i])
            if self.node.truth_publishers(slot):
                stale += 1
            else:
                gone.append(names[i])
                self.attached[slot] = 0
        self.stale = stale
        return gone


class PatternAgents(_NodeBase):
    """
    The error node's side of ``agent_pattern`` (a mixin of ``GpsErrorNode``).

    Slots are the node's agent indices; in pattern mode there is one profile
    group whose engine has one row per slot. :class:`AgentWatcher` calls
    these to open and close agents.
    """

    # what the node that mixes this in holds (GpsErrorNode), per slot where a list
    groups: list[ProfileGroup]
    agents: list[str | None]
    subs: list[Any]
    pubs: list[Any]
    vel_pubs: list[Any]
    pose_pubs: list[Any]
    sub_handles: list[Any]
    pub_handles: list[Any]
    seed: int
    input_type: str
    slot_group: IntArray
    slot_local: IntArray
    _open: Callable[[int, str, str], None]
    now_ns: Callable[[], int]

    def _agent_pattern(self, cfg: Mapping[str, Any]) -> AgentPattern | None:
        """Return the parsed agent_pattern, or None when it is off."""
        if not cfg['agent_pattern']:
            return None
        if cfg['agents'] or cfg['agent_profiles']:
            raise ConfigError(
                'parameter \'agent_pattern\': set together with \'agents\' or '
                '\'agent_profiles\': expected one way of naming the agents (the '
                'pattern serves every agent with the one profile)')
        msg_type = conversions.TRUTH_INPUTS[self.input_type][1]
        type_name = f'{msg_type.__module__.split(".")[0]}/msg/{msg_type.__name__}'
        return AgentPattern(cfg['agent_pattern'], self.get_namespace(), type_name)

    def prepare_attach(self) -> None:
        """Load what attaching an agent needs, before the first one comes."""
        self.groups[0].engine.prepare_attach()

    def open_agents(self, new: Sequence[tuple[str, str]],
                    fix_topics: Sequence[str]) -> list[int]:
        """Serve ``new`` [(name, truth topic)] on ``fix_topics``; return their slots."""
        free = [i for i, a in enumerate(self.agents) if a is None]
        if len(free) < len(new):
            self._grow(max(len(new) - len(free), len(self.agents)))
            free = [i for i, a in enumerate(self.agents) if a is None]
        slots = free[:len(new)]
        for slot, (name, truth_topic), fix_topic in zip(slots, new, fix_topics):
            self.agents[slot] = name
            self._open(slot, truth_topic, fix_topic)
        self.groups[0].engine.attach(slots, [agent_key(self.seed, n) for n, _ in new])
        return slots

    def close_agents(self, slots: Sequence[int]) -> None:
        """Release ``slots``: subscription, publisher and model state."""
        for slot in slots:
            self.destroy_subscription(self.subs[slot])
            self.destroy_publisher(self.pubs[slot])
            for extra in (self.vel_pubs, self.pose_pubs):
                if extra[slot] is not None:
                    self.destroy_publisher(extra[slot])
                    extra[slot] = None
            self.agents[slot] = self.subs[slot] = self.pubs[slot] = None
            self.sub_handles[slot] = self.pub_handles[slot] = None
        self.groups[0].engine.detach(slots)

    def _grow(self, n: int) -> None:
        """Add ``n`` free slots (pattern mode: one profile group)."""
        self.groups[0].engine.grow(n)
        for lst in (self.agents, self.subs, self.pubs, self.sub_handles, self.pub_handles,
                    self.vel_pubs, self.pose_pubs):
            lst.extend([None] * n)
        size = len(self.agents)
        self.groups[0].members = np.arange(size)
        self.slot_group = np.zeros(size, dtype=np.int64)
        self.slot_local = np.arange(size)

    def newest_truth_ns(self) -> IntArray:
        """Return each slot's newest truth stamp (ns; -1 for none)."""
        return self.groups[0].engine.truth.newest

    def truth_publishers(self, slot: int) -> int:
        """Return how many publishers the truth topic of ``slot`` has."""
        return self.subs[slot].get_publisher_count()
