"""Example campaign files (JSON), shipped as mountid.examples for `mountid demo`."""
