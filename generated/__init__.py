"""Generated modules, one per description in derivations/ (see `make generate`)."""
