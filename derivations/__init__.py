"""Machine descriptions, one TOML file per machine (data; shipped as mountid.derivations)."""
