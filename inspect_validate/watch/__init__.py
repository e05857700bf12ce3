"""On-line verification of a running station: ``watch`` cycles (:mod:`.loop`), drift
charts (:mod:`.drift`), the history database (:mod:`.history`) and the HTTP status
endpoint (:mod:`.serve`)."""
