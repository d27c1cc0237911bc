"""Status latency of the analysis node (used by its tests and bench_analysis)."""

def status_delays(updates, statuses) -> list:
    """Return the analysis node's status latencies [s] (required to stay within 50 ms).

    For each joint_states ``(receipt, stamp)``, the wall time [s] until the first status
    ``(receipt, stamp)`` that reflects it (same stamp or a later one) is received; both lists
    in receipt order, stamps in integer ns.
    """
    delays, k = [], 0
    for receipt, stamp in updates:
        while k < len(statuses) and (statuses[k][1] < stamp or statuses[k][0] < receipt):
            k += 1
        if k == len(statuses):
            break
        delays.append(statuses[k][0] - receipt)
    return delays

