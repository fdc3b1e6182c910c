"""Using a trained model: the streaming engine (Python API), an OpenAI-compatible server and a web demo.

The engine needs only the ``train`` extra; the server and the demo need the ``serve`` extra (FastAPI, uvicorn,
gradio), imported only when used.
"""

from tacreasoner.serve.engine import DecodeTimeout, Prompt, Reply, RequestError, Sampling, TactileEngine
from tacreasoner.serve.stream import Delta

__all__ = ["DecodeTimeout", "Delta", "Prompt", "Reply", "RequestError", "Sampling", "TactileEngine"]
