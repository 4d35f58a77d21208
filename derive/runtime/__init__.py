"""The thin runtime around the generated code: scenes, model choice, specialised C."""
