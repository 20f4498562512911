"""protocol: the controller link (codec, asyncio client), the measuring-arm line reader and the
RAPID server module. Carries numbers, not models: imports nothing of screwcal, service or
simulators. Built in the controller-link issue."""
