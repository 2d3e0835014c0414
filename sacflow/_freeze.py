"""Imported last by the campaign's fork server: ``gc.freeze()`` what its imports created.

The Python manual (``gc.freeze``) advises it for a process that forks without exec: objects
created before the freeze move to a permanent generation that the collector no longer visits,
so the workers forked from the server do not walk the server's imported objects (about 88
thousand for an elastic campaign) in each of their full collections. Measured on the 2-core
development machine, eight 128 × 128 × 16 elastic cases on two forked workers, three
alternating pairs of runs: the workers' user time over the eight cases went from 19.2-20.1 s to
18.2-19.0 s. Only the fork server imports this module (:data:`sacflow.campaign.FORK_SERVER_LAST`).

No ``gc.collect()`` first: it took 0.05 s, on the way to the workers' start, to free the little
garbage the imports leave, and the manual's recipe for forking servers has none.
"""

import gc

gc.freeze()
