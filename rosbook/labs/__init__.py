"""Each lab's checks (``labNN``) and the probes they share (``probes``)."""
