"""The typed contract: the OpenAPI document is whole, and the models match what is sent."""

from __future__ import annotations

import dataclasses

import pytest

from backend.api.messages import WS_MODELS
from backend.api.schemas import Telemetry
from backend.app import create_app
from backend.link import Telemetry as LinkTelemetry
from backend.settings import Settings


@pytest.fixture(scope="module")
def doc() -> dict:
    return create_app(Settings()).openapi()  # no server, no station


def _operations(doc):
    for path, methods in doc["paths"].items():
        for method, op in methods.items():
            yield path, method, op


def test_every_operation_documents_its_answer_and_its_errors(doc):
    schemas = doc["components"]["schemas"]
    for path, method, op in _operations(doc):
        ok = op["responses"].get("200") or op["responses"].get("201")
        assert ok is not None, (method, path)
        content = ok.get("content", {})
        json_schema = content.get("application/json", {}).get("schema")
        # JSON answers name their model; files name their media type.
        assert json_schema or content, (method, path)
        if json_schema:
            assert json_schema != {}, f"{method} {path} has no response model"
        for code, answer in op["responses"].items():
            if code.startswith(("4", "5")):
                # Every error body says what went wrong in its "detail" sentence.
                ref = answer["content"]["application/json"]["schema"]["$ref"]
                model = schemas[ref.rsplit("/", 1)[-1]]
                assert "detail" in model.get("required", []), (method, path, code, ref)
        if path != "/api/health":
            assert "401" in op["responses"] and "503" in op["responses"], (method, path)
    assert "HTTPValidationError" not in schemas


def test_the_operator_token_is_a_security_scheme(doc):
    assert doc["components"]["securitySchemes"] == {
        "OperatorToken": {
            "type": "http",
            "scheme": "bearer",
            "description": "The operator token, printed at start and kept in DATA_DIR/token.",
        }
    }
    arm = doc["paths"]["/api/vehicle/arm"]["post"]
    assert arm["security"] == [{"OperatorToken": []}]
    assert {"401", "409", "422", "503", "504"} <= set(arm["responses"])
    status = doc["paths"]["/api/status"]["get"]
    assert status["security"] == [{}, {"OperatorToken": []}]  # open unless configured
    upload = doc["paths"]["/api/reference"]["post"]["responses"]
    assert {"401", "413", "415", "422"} <= set(upload)


def test_the_websocket_messages_are_in_the_document(doc):
    schemas = doc["components"]["schemas"]
    for model in WS_MODELS:
        assert model.__name__ in schemas
    assert "/ws" in doc["info"]["description"]


def test_the_telemetry_model_has_every_field_of_the_snapshot():
    assert set(Telemetry.model_fields) == {f.name for f in dataclasses.fields(LinkTelemetry)}
    Telemetry.model_validate(LinkTelemetry().to_dict())
