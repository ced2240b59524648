"""Front-end plumbing shared by `sloshid run` and `sloshid batch`: declarative pipelines with
content-hash caching, stage options from TOML, the Dask batch, and the pipeline index page.

May import: every stage package (never sloshid.cli).
"""
