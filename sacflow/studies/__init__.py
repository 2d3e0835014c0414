"""Studies built on campaigns and comparison stages (the dent study). See ``docs/dent-study.md``."""
