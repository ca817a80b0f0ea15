# One image for every process of an arena (server, coach, players, trainer): `docker compose up`.
FROM python:3.11-slim
WORKDIR /keepaway
COPY pyproject.toml README.md ./
COPY keepaway ./keepaway
COPY protocol ./protocol
COPY core ./core
COPY server ./server
COPY agents ./agents
COPY coach ./coach
COPY runner ./runner
COPY trainer ./trainer
COPY viewer ./viewer
COPY rcss ./rcss
# every kernel compiled once into the image's cache: containers start playing at once
RUN pip install --no-cache-dir . && keepaway compile
ENTRYPOINT ["keepaway"]
