"""Authenticated commands (AUTOSAR SecOC, opt-in): keys, persisted freshness, signing, checking.

The pure codec is `bywire.protocol.secoc`; this package holds what has state or touches files:
the key file and its permissions (`keys`), the freshness values that survive restarts
(`freshness`), the sender's signer and the controller's pairing check (`session`).
"""
