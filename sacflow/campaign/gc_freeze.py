"""Imported last by the campaign's fork server: ``gc.freeze()`` what its imports created.

The Python manual (``gc.freeze``) advises it for a process that forks without exec: objects
created before the freeze move to a permanent generation that the collector no longer visits,
so the workers forked from the server do not walk the server's imported objects (about 88
thousand for an elastic campaign) in each of their full collections, which saves the workers a
few percent of their time (``docs/performance.md``). Only the fork server imports this module
(:data:`sacflow.campaign.FORK_SERVER_LAST`).

No ``gc.collect()`` first: it would delay the workers' start to free the little garbage the
imports leave, and the manual's recipe for forking servers has none.
"""

import gc

gc.freeze()
