"""Agent processes that read and write the working memory."""
