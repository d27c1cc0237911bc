"""Real-time scheduling of the thread that integrates the plant (parameter ``realtime_priority``).

On a loaded machine the kernel's fair scheduler shares the CPU between the plant and every
other process, so a plant that needs half a core can still fall behind the wall clock. HIL
benches run their control loop under ``SCHED_FIFO`` (as ros2_control's controller manager
does with its ``thread_priority``): the thread then runs whenever it is ready, before every
normal process. :class:`FifoScheduling` puts the calling thread under ``SCHED_FIFO`` at the
priority asked for, or back under the normal policy for 0. Changing the policy needs
CAP_SYS_NICE or an ``rtprio`` limit (``ulimit -r``, /etc/security/limits.conf); when the system
refuses, the thread stays as it was and :attr:`state` says why (one warning, not an error:
the plant still runs, as ros2_control does).

Only the thread that calls :meth:`apply` is affected (Linux applies a policy per thread):
the node calls it from the thread that integrates (the plant's own thread,
:mod:`abb_ros.runtime.plant_thread`), so the executor, the middleware's threads and the rest of
the process keep the normal policy. The node asks for 0 when it runs as fast as possible
(``real_time_factor`` 0): a FIFO thread that never sleeps would hold a core.
"""

from __future__ import annotations

import os

__all__ = ['FifoScheduling']


class FifoScheduling:
    """Wanted and applied scheduling of one thread (the one calling :meth:`apply`)."""

    def __init__(self):
        self.wanted = 0         # SCHED_FIFO priority wanted, 0 = the normal policy
        self.applied = 0        # what the thread has (as far as this object set it)
        self.state = 'normal'   # for diagnostics: 'SCHED_FIFO <p>', 'normal', or why not
        self._tried = 0         # the last priority tried (not retried until it changes)

    def want(self, priority: int) -> None:
        """Want SCHED_FIFO at ``priority`` (0: the normal policy) from the next apply."""
        self.wanted = int(priority)

    @property
    def pending(self) -> bool:
        """A wanted policy not tried yet (:meth:`apply` has something to do)."""
        return self.wanted != self._tried

    def apply(self) -> str:
        """Set the calling thread's policy to what is wanted, once per change.

        Returns '' or a one-line warning (the system refused; the thread keeps its policy).
        """
        if not self.pending:
            return ''
        self._tried = self.wanted
        try:
            if self.wanted > 0:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(self.wanted))
            else:
                os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        except (OSError, AttributeError) as exc:
            reason = getattr(exc, 'strerror', None) or str(exc)
            self.state = (f'normal (SCHED_FIFO {self.wanted} refused: {reason}; needs '
                          f'CAP_SYS_NICE or an rtprio limit)')
            return (f'realtime_priority {self.wanted} refused by the system ({reason}): the '
                    'integration runs under the normal scheduler (give the user an rtprio '
                    'limit, e.g. ulimit -r 99, or CAP_SYS_NICE)')
        self.applied = self.wanted
        self.state = f'SCHED_FIFO {self.wanted}' if self.wanted else 'normal'
        return ''

    def apply_logged(self, logger) -> None:
        """Apply the wanted policy to the calling thread; log a refusal as one warning."""
        warning = self.apply()
        if warning:
            logger.warning(warning)
        elif self.applied:
            logger.info(f'integrating under {self.state}')
