"""TacReasoner: tactile-language reasoning with a dynamic-aware tactile encoder."""

from tacreasoner._hf_registration import install as _install_hf_registration

__version__ = "0.1.0"

# AutoConfig / AutoModelForCausalLM / AutoProcessor learn about TacReasoner without importing torch here.
_install_hf_registration()
