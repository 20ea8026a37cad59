"""Compiled kernel of :mod:`labkit.motion.stall`: a program's lines through the link, the
parser and the planner, one after the other."""

from __future__ import annotations

import numpy as np

from labkit._jit import jit


@jit(python_below=1_000_000)  # ~0.9 µs an element as Python (five per line: 2,418 lines 11 ms), 1 s at 1 M
def stream_lines(nbytes, first_block, last_block, dur, tau, parse_s, window, planner_blocks,
                 limit, flush_s, parse_first, sync):
    """When each sent line leaves the sender, arrives and is parsed; when each block runs.

    ``nbytes[i]`` bytes of sent line i (newline included) make blocks ``first_block[i]``
    … ``last_block[i] - 1`` of durations ``dur`` (s). The sender keeps the characters in
    flight (sent, not yet answered) below ``limit`` (GRBL's character counting); a byte
    takes ``tau`` s on the wire; the parser takes ``parse_s`` a line, one after the other:
    with ``parse_first`` (GRBL: ``gc_execute_line`` before ``mc_line`` waits) a parsed line
    then waits for a free slot in the planner (``planner_blocks``), else (the labkit firmware:
    a line is executed only once a slot is free) the parse starts once a slot is free. Block j runs after block j - 1 once it
    is ready: once block j + ``window`` is parsed (0: at once), the last ``window`` blocks
    ``flush_s`` after the last line was parsed. A line with ``sync[i]`` (GRBL's M3/M4/M5
    change) is answered only once every block before it has ended, and the next line is
    read after that; the blocks whose window reaches past it are ready when it is parsed
    (the controller runs out its planner).

    Returns (sent, arrived, parsed) per line and (start, end) per block, s.
    """
    n_sent = nbytes.shape[0]
    nb = dur.shape[0]
    sent = np.zeros(n_sent)
    arrived = np.zeros(n_sent)
    parsed = np.zeros(n_sent)
    block_parsed = np.full(nb, np.inf)
    start = np.zeros(nb)
    end = np.zeros(nb)
    done = 0                    # blocks whose start and end are known
    head = 0                    # oldest sent line not yet answered (lines head … i-1 in flight)
    in_flight_bytes = 0
    t_sender = 0.0
    wire_free = 0.0
    parse_free = 0.0
    for i in range(n_sent):
        n = nbytes[i]
        t = t_sender
        while head < i and in_flight_bytes + n >= limit:      # GRBL's character counting
            in_flight_bytes -= nbytes[head]
            t = max(t, parsed[head])
            head += 1
        t_sender = t
        sent[i] = t
        wire_free = max(wire_free, t) + n * tau
        arrived[i] = wire_free
        # one line after the other: the next line is read once this one has entered the planner
        ready = max(arrived[i], parse_free) + (parse_s if parse_first else 0.0)
        b0 = first_block[i]
        b1 = last_block[i]
        if sync[i] and b0 > 0:
            # parsed, then it waits until the motion before it has ended
            t_sync = ready + (0.0 if parse_first else parse_s)
            done = _settle(done, b0, block_parsed, start, end, dur, window, t_sync, b0)
            ready = max(ready, end[b0 - 1] - (0.0 if parse_first else parse_s))
        need = b1 - 1 - planner_blocks      # this block must have left the planner for a free slot
        if b1 > b0 and need >= 0:
            done = _settle(done, min(need + 1, max(0, b0 - window)), block_parsed, start, end, dur,
                           window, np.inf, nb)
            if done > need:
                ready = max(ready, end[need])
        parse_free = ready + (0.0 if parse_first else parse_s)
        parsed[i] = parse_free
        for b in range(b0, b1):
            block_parsed[b] = parse_free
        in_flight_bytes += n
        done = _settle(done, max(0, b1 - window), block_parsed, start, end, dur, window, np.inf, nb)
    last = parsed[n_sent - 1] if n_sent else 0.0
    _settle(done, nb, block_parsed, start, end, dur, window, last + flush_s, nb)
    return sent, arrived, parsed, start, end


@jit(python_below=1_000_000)  # as stream_lines, which calls it
def _settle(done, upto, block_parsed, start, end, dur, window, flush_at, seg_end):
    """Start and end of blocks ``done … upto - 1``; block j is ready when block j + window is
    parsed (past block ``seg_end`` - 1, the last before the job's end or a sync: at
    ``flush_at``). Returns the new ``done``."""
    while done < upto:
        j = done
        if j + window < seg_end:
            ready = block_parsed[j + window]
        else:
            ready = max(flush_at, block_parsed[seg_end - 1])
        start[j] = ready if j == 0 else max(end[j - 1], ready)
        end[j] = start[j] + dur[j]
        done += 1
    return done
