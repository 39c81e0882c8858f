"""A sweep's configuration: the :class:`~rattlesweep.sweep.Sweep` specification
(:mod:`.spec`), the parameters it may sweep (:mod:`.params`), the checks and normal form of
its settings (:mod:`.schema`), its grid (:mod:`.grid`), the combinations of extremes and
the tile size (:mod:`.corners`), its TOML file (:mod:`.toml_io`), body files
(:mod:`.body_file`) and the demo configuration (:mod:`.demo`)."""
