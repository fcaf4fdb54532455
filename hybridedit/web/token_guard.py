"""The token that keeps other users of the machine (and other sites in the browser) out of the server.

The URL printed at start carries the token as ``?secret=``; the first page load with it
sets an HttpOnly, SameSite=Strict cookie so that the page's assets and its websocket
(which carry no query) are let in too. Any other HTTP request is answered 403. The same
token is wslink's ``authKey``, checked again when the websocket session starts.
"""

from __future__ import annotations

import secrets

COOKIE = "hybridedit_token"
"""The cookie the token is kept in after the first page load."""


def new_token() -> str:
    """A random URL-safe token that is not all digits (wslink would read a numeric ``authKey`` as a
    number, and it would no longer equal the ``secret`` the client sends)."""
    while True:
        token = secrets.token_urlsafe(18)
        if not token.isdigit():
            return token


def token_middleware(token: str):
    """An aiohttp middleware: requests with ``?secret=token`` or the token's cookie pass, others get 403.

    Parameters
    ----------
    token : the server's token.
    """
    from aiohttp import web

    @web.middleware
    async def require_token(request, handler):
        given = request.query.get("secret")
        by_query = given is not None and secrets.compare_digest(given, token)
        by_cookie = secrets.compare_digest(request.cookies.get(COOKIE, ""), token)
        if not (by_query or by_cookie):
            return web.Response(status=403, text="forbidden: open the URL hybridedit web printed (with its token)")
        try:
            response = await handler(request)
        except web.HTTPException as redirect:  # "/" answers with a redirect to index.html: it takes the cookie too
            response = redirect
        if by_query and not getattr(response, "prepared", False):
            response.set_cookie(COOKIE, token, httponly=True, samesite="Strict")
        if isinstance(response, web.HTTPException):
            raise response
        return response

    return require_token
