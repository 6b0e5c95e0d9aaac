"""The clients' typed methods are the table's: one per operation, named by its declaration,
taking and returning the operation's models; sync and async share each one."""

import inspect
import typing

from plotgate.clients import client
from plotgate.clients.client import AsyncClient, Client
from plotgate.service.table import ENDPOINTS


def _methods() -> dict[str, client.TypedMethod]:  # type: ignore[type-arg]
    return {
        n: m for n, m in vars(client.OperationMethods).items() if isinstance(m, client.TypedMethod)
    }


def test_one_typed_method_per_operation():
    named = {e.client_method for e in ENDPOINTS.values() if e.client_method is not None}
    assert set(_methods()) == named


def test_each_method_takes_and_returns_its_operations_models():
    methods = _methods()
    for name, endpoint in ENDPOINTS.items():
        assert endpoint.client_method is not None, name  # each of today's has one
        method = methods[endpoint.client_method]
        assert method.endpoint is endpoint, name
        assert method.request is endpoint.request, name
        assert method.response is endpoint.response, name
        built = typing.get_type_hints(method.build)["return"]  # _given's is its TypeVar
        assert isinstance(built, typing.TypeVar) or built is endpoint.request, name


def test_sync_and_async_share_each_method():
    for endpoint in ENDPOINTS.values():
        assert endpoint.client_method is not None, endpoint.name
        assert endpoint.client_method not in vars(Client), endpoint.name
        assert endpoint.client_method not in vars(AsyncClient), endpoint.name
        assert getattr(Client, endpoint.client_method) is getattr(
            AsyncClient, endpoint.client_method
        )


def test_no_other_public_method_names_an_operation():
    table = {e.client_method for e in ENDPOINTS.values()}
    for cls in (Client, AsyncClient):
        own = {n for n, v in vars(cls).items() if not n.startswith("_") and inspect.isfunction(v)}
        assert not own & table, cls
