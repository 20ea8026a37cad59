"""G-code: parse text into Moves, arcs, emit Moves as text, simulate."""
