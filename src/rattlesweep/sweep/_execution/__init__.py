"""Running a sweep: the entry points and their checks, and the one loop that runs an
output's stages (:mod:`.run`; a stage: :mod:`.stage`), tiles on threads or a dask cluster
(:mod:`.execute`), one tile's computation (:mod:`.tiles`), the time and size
estimate (:mod:`.estimate`), progress reports (:mod:`.progress`) and the lock that keeps
two runs off one output (:mod:`.lock`)."""
