"""The network layer of the working memory: the sync protocol, replication over Zenoh, ``wm.connect``,
the key layout, Zenoh configs and ``wm serve``. The graph above it knows nothing of Zenoh."""
