"""What every gateway shares, one module per concept.

* ``errors``: :class:`GatewayError`; ``filters``: :class:`NameFilter` (regexes or globs);
  ``graph_watcher``: :class:`GraphWatcher` (a thread that follows the graph);
  ``watched_topics``: :class:`Taps` (a raw subscription per watched topic, latched messages
  kept); ``send_queue``: :class:`SendQueue` (a client's bounded outbox); ``drop_notice``:
  :class:`DropNotices` (when to tell a slow client of its drops); ``entities``: the
  gateway's node, the clients made for clients (:class:`ClientCache`) and the QoS of their
  publishers (:func:`publisher_qos`).
* ``listen`` (address, port, TLS), ``origins`` (which browser pages may connect),
  ``admission`` (how many clients are served at once), ``throttle``
  (per-topic rate limits), ``views`` (the graph views the gateways show), ``json_types``,
  ``heap`` (a gateway process's malloc thresholds).

Nothing here imports a gateway (``foxglove``, ``rosbridge``): import-linter checks it.
"""
